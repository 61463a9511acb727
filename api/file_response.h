// Responses that carry a file or a block of static bytes: streamed through a
// bounded buffer (never the whole file in memory per request), with one byte
// range served as 206 where the gate passed one on (api/byte_range.h).
#pragma once

#include <httplib.h>

#include <filesystem>
#include <string_view>

namespace dfsm::api {

// Serves the regular file at `path`, opened now: a file deleted or replaced
// while it is being sent is sent as it was when opened. Throws
// std::system_error when it cannot be opened.
void ServeFile(const httplib::Request& request, httplib::Response& response,
               const std::filesystem::path& path, const char* content_type);

// Serves `bytes`, which must outlive the response (the web page's files,
// compiled into dfsmd). Whole, they are copied into the response so that
// httplib compresses them as the client accepts (the page's first load is
// ~20 KB compressed, 800 KB plain); a range is sent from the bytes themselves.
void ServeStaticBytes(const httplib::Request& request, httplib::Response& response,
                      std::string_view bytes, const char* content_type);

}  // namespace dfsm::api
