// The values of the report programs' options (calibration_sweep,
// depth_sweep, init_comparison, tum_benchmark): a value must be all of its
// text, written plainly (digits, a sign only where negative values make
// sense, no hexadecimal), and in range, or std::invalid_argument names the
// option and what it got, and the program prints that and exits 2. std::atoi,
// which they used before, read "abc" as 0 and "3x" as 3 without a word.
#pragma once

#include <cstdint>
#include <string>

namespace dfsm {

// A whole number of at least `least` ("--frames takes a whole number >= 1,
// got 'abc'").
int WholeNumber(const char* option, const std::string& text, int least);

// A finite number > 0 (a scale, a sigma that divides).
double PositiveNumber(const char* option, const std::string& text);

// A finite number >= 0 (a sigma or a penalty where 0 means off).
double NonNegativeNumber(const char* option, const std::string& text);

// A random seed: a whole number from 0 to 2^64 - 1.
uint64_t SeedNumber(const char* option, const std::string& text);

// A switch: "on" (true) or "off" (false), nothing else.
bool OnOff(const char* option, const std::string& text);

}  // namespace dfsm
