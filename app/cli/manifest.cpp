// `collide manifest DIR... [--out LIST]`: the shot files of one or more
// folders as a manifest (absolute paths, one a line) for `collide analyze
// --manifest` and `collide fit --manifest` (docs/cluster.md).
#include "app/manifest.hpp"

#include <iostream>

#include "app/cli/command.hpp"
#include "app/store/atomic_file.hpp"

namespace {

void setupManifest(CLI::App& sub, std::function<int()>& run) {
  auto folders = std::make_shared<std::vector<std::string>>();
  auto out = std::make_shared<std::string>();
  auto chunk = std::make_shared<long>(0);
  sub.add_option("folders", *folders, "Shot folders")->required();
  sub.add_option("--out", *out, "Write the manifest here (default: stdout)");
  sub.add_option("--chunk", *chunk,
                 "Also say on stderr how many array tasks of this many shots it makes")
      ->check(CLI::PositiveNumber);
  sub.footer(
      "Lists every shot file (*.h5) of each folder in name order, one absolute path a line.\n"
      "Then: sbatch --array=0-<tasks-1> docs/examples/analyze-array.sbatch LIST "
      "(docs/cluster.md).");
  run = [=] {
    auto files = collide::app::listShotFiles(*folders);
    if (!files) {
      std::cerr << "collide manifest: " << files.error().message << "\n";
      return collide::cli::kExitBadInput;
    }
    std::string text;
    for (const auto& f : *files) text += f + "\n";
    if (out->empty() || *out == "-") {
      std::cout << text << std::flush;
    } else if (auto st = collide::app::writeTextFile(*out, text); !st) {
      std::cerr << "collide manifest: " << st.error().message << "\n";
      return collide::cli::kExitFailure;
    }
    const long n = static_cast<long>(files->size());
    std::cerr << "collide manifest: " << n << " shot file" << (n == 1 ? "" : "s") << " from "
              << folders->size() << " folder" << (folders->size() == 1 ? "" : "s");
    if (*chunk > 0) {
      const long tasks = collide::app::tasksFor(n, *chunk);
      std::cerr << ": " << tasks << " task" << (tasks == 1 ? "" : "s") << " of " << *chunk
                << " (sbatch --array=0-" << tasks - 1 << ")";
    }
    std::cerr << "\n";
    return collide::cli::kExitOk;
  };
}

}  // namespace

COLLIDE_COMMAND(manifest, "List the shot files of folders, one a line, for cluster batch jobs",
                setupManifest);
