// What png_encode and png_decode both hand to libpng.
#pragma once

#include <png.h>

#include <string>

namespace dfsm::libpng {

// PNG stores 16-bit samples big-endian; a little-endian host swaps them.
constexpr bool IsBigEndianHost() { return __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__; }

// libpng reports errors by longjmp; the message is kept in the std::string
// given as the error pointer, for the exception thrown once control is back
// in C++ (unwinding through libpng is not safe).
inline void KeepErrorMessage(png_structp png, png_const_charp message) {
  *static_cast<std::string*>(png_get_error_ptr(png)) = message;
  png_longjmp(png, 1);
}

inline void IgnoreWarning(png_structp, png_const_charp) {}

}  // namespace dfsm::libpng
