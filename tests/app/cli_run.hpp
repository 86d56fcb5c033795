#pragma once
// Running the built `collide` program from a test, as a user runs it.
#include <sys/wait.h>

#include <cstdio>
#include <filesystem>
#include <string>

#include "tests/app/shot_fixtures.hpp"

namespace collide::testing {

struct CommandRun {
  int exit_code = -1;
  std::string out, err;
};

/// Runs `collide ARGS` through the shell (`args` already quoted, see q());
/// stderr goes through a file in `scratch`. `shell_prefix` runs first in the
/// same shell (e.g. "ulimit -f 2000;").
inline CommandRun runCollide(const std::string& args, const ScratchDir& scratch,
                             const std::string& shell_prefix = "") {
  const std::string err_file = scratch.file("stderr.txt");
  const std::string command = shell_prefix + std::string(COLLIDE_BINARY_DIR) + "/app/collide " +
                              args + " 2>'" + err_file + "'";
  CommandRun run;
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) return run;
  char buf[4096];
  std::size_t n;
  while ((n = fread(buf, 1, sizeof buf, pipe)) > 0) run.out.append(buf, n);
  const int status = pclose(pipe);
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  run.err = readAll(err_file);
  std::filesystem::remove(err_file);
  return run;
}

/// `s` in single quotes for the shell.
inline std::string q(const std::string& s) {
  return "'" + s + "'";
}

}  // namespace collide::testing
