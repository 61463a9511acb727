#include "api/openapi.h"

#include <string_view>

// api/openapi.json, kept by hand and checked against the options table and the
// routes by openapi_test.cc, is included by the assembler (.incbin) so the
// binary serves exactly the committed file; CMake passes its path.
__asm__(".section .rodata\n.balign 16\ndfsm_openapi_json:\n.incbin \"" DFSM_OPENAPI_JSON
        "\"\ndfsm_openapi_json_end:\n.byte 0\n.previous\n");
// Hidden: the labels are local to this object, so they must be addressed
// PC-relative. With default visibility the compiler goes through the GOT, and
// on arm64 both GOT entries resolved to the start of .rodata (the document
// read back empty and openapi.json answered 500; found under qemu-user).
extern "C" __attribute__((visibility("hidden")))
const char dfsm_openapi_json[] __asm__("dfsm_openapi_json");
extern "C" __attribute__((visibility("hidden")))
const char dfsm_openapi_json_end[] __asm__("dfsm_openapi_json_end");

namespace dfsm::api {

const nlohmann::json& OpenApiDocument() {
  static const nlohmann::json document = nlohmann::json::parse(std::string_view(
      dfsm_openapi_json, static_cast<size_t>(dfsm_openapi_json_end - dfsm_openapi_json)));
  return document;
}

}  // namespace dfsm::api
