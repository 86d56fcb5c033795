// `collide`: the command-line program. Subcommands register themselves from
// their own files in this folder (see command.hpp).
#include <algorithm>
#include <csignal>
#include <iostream>
#include <memory>

#include "app/cli/command.hpp"
#include "app/version.hpp"

int main(int argc, char** argv) {
  using namespace collide::cli;
  // A file size limit (ulimit -f) must fail the write with EFBIG, which
  // becomes a message naming the file, not kill the program mid-save.
  std::signal(SIGXFSZ, SIG_IGN);
  CLI::App app{
      "collide: fire, record and measure sphere collisions (Walton's model).\n"
      "Every device has a simulated backend: try `collide campaign --rig config/sim.toml`."};
  app.set_version_flag("--version", std::string("collide ") + collide::kVersion);
  app.require_subcommand(1);
  app.get_formatter()->column_width(30);

  auto& commands = registry();
  std::sort(commands.begin(), commands.end(),
            [](const auto& a, const auto& b) { return a.name < b.name; });
  std::vector<std::function<int()>> runners(commands.size());
  std::vector<CLI::App*> subs;
  for (std::size_t i = 0; i < commands.size(); ++i) {
    CLI::App* sub = app.add_subcommand(commands[i].name, commands[i].description);
    commands[i].setup(*sub, runners[i]);
    subs.push_back(sub);
  }

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    int code = app.exit(e);
    return code == 0 ? 0 : kExitBadInput;
  }
  for (std::size_t i = 0; i < subs.size(); ++i) {
    if (subs[i]->parsed() && runners[i]) {
      try {
        return runners[i]();
      } catch (const std::exception& e) {
        // Only bugs reach here (user errors are Result values): say so plainly.
        std::cerr << "collide " << commands[i].name << ": internal error: " << e.what()
                  << "\nPlease report this with the command line and input that caused it.\n";
        return kExitFailure;
      }
    }
  }
  return kExitFailure;
}
