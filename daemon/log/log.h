// Log lines with syslog priorities, for dfsmd and dfsm-capture. Under systemd
// (stderr connected to the journal: JOURNAL_STREAM is set) each line starts
// with "<N>", which journald reads as its priority (sd-daemon(3)), so
// `journalctl -u dfsmd -p warning` shows device loss and failed jobs alone;
// elsewhere the line is plain. Each call writes one whole line: lines of
// different threads never interleave.
#pragma once

#include <string_view>

namespace dfsm::log {

enum class Priority { kError = 3, kWarning = 4, kNotice = 5, kInfo = 6, kDebug = 7 };

// "<program>: <message>" at `priority`.
void Write(Priority priority, std::string_view message);

inline void Error(std::string_view message) { Write(Priority::kError, message); }
inline void Warning(std::string_view message) { Write(Priority::kWarning, message); }
inline void Notice(std::string_view message) { Write(Priority::kNotice, message); }
inline void Info(std::string_view message) { Write(Priority::kInfo, message); }

// Write(), at most `per_minute` lines a minute for `key`: what hostile clients
// can cause (refused requests) must not flood the journal. The first line
// after a quiet minute says how many were left out. Returns whether it wrote.
bool WriteLimited(Priority priority, std::string_view key, std::string_view message,
                  int per_minute = 20);

}  // namespace dfsm::log
