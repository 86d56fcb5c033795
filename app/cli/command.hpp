#pragma once
// Each `collide` subcommand lives in its own file in app/cli/ and registers
// itself with one line at the bottom of that file:
//
//   COLLIDE_COMMAND(predict, "What Walton's model predicts for a planned shot (JSON in, JSON out)",
//                   setupPredict);
//
// where `void setupPredict(CLI::App& sub, std::function<int()>& run)` adds the
// subcommand's options and sets `run` to the code that executes it. `run`
// returns the process exit status: 0 success, 1 failure while working,
// 2 bad input (with a one-line message on stderr naming the field or file).
#include <CLI/CLI.hpp>
#include <functional>
#include <string>
#include <vector>

namespace collide::cli {

using Setup = void (*)(CLI::App& sub, std::function<int()>& run);

struct CommandInfo {
  std::string name;
  std::string description;
  Setup setup;
};

inline std::vector<CommandInfo>& registry() {
  static std::vector<CommandInfo> commands;
  return commands;
}

struct Registrar {
  Registrar(const char* name, const char* description, Setup setup) {
    registry().push_back({name, description, setup});
  }
};

/// Exit statuses shared by every subcommand.
inline constexpr int kExitOk = 0;
inline constexpr int kExitFailure = 1;
inline constexpr int kExitBadInput = 2;

}  // namespace collide::cli

#define COLLIDE_COMMAND_CAT2(a, b) a##b
#define COLLIDE_COMMAND_CAT(a, b) COLLIDE_COMMAND_CAT2(a, b)
#define COLLIDE_COMMAND(name, description, setup)                                   \
  static ::collide::cli::Registrar COLLIDE_COMMAND_CAT(collide_command_, __LINE__)( \
      #name, description, setup)
