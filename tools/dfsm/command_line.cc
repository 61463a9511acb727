#include "tools/dfsm/command_line.h"

#include <iostream>

namespace dfsm::tools {

std::optional<int> ParseCommandLine(CLI::App& app, const Args& args) {
  try {
    app.parse(std::vector<std::string>(args.rbegin(), args.rend()));  // CLI11 wants them reversed
  } catch (const CLI::CallForHelp&) {
    std::cout << app.help();
    return 0;
  } catch (const CLI::ParseError& e) {
    throw UsageError(e.what());
  }
  return std::nullopt;
}

CLI::Validator FrameCount() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        int frames = 0;
        if (CLI::detail::lexical_cast(text, frames) && (frames == 0 || frames >= 3)) return "";
        return "must be 0 (all) or at least 3, got " + text;
      },
      "0|N>=3");
}

}  // namespace dfsm::tools
