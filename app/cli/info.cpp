// `collide info FILE`: what a high-speed camera file holds (Photron MRAW with
// its .cih/.cihx, Phantom CINE, pco B16), read from its header without
// decoding frames.
#include <iostream>

#include "app/cli/command.hpp"
#include "vision/footage.hpp"

namespace {

void setupInfo(CLI::App& sub, std::function<int()>& run) {
  auto files = std::make_shared<std::vector<std::string>>();
  sub.add_option("FILE", *files,
                 "A .mraw (with its .cihx/.cih beside it), .cih, .cihx, .cine or pco .b16")
      ->required();
  sub.footer(
      "Prints format, frame size, frame count, frame rate, exposure, bits, frame ids\n"
      "relative to the trigger and the pixel size if the file records one. Exit status:\n"
      "0 all files read, 2 a file is missing, damaged or of another kind.");
  run = [files] {
    int status = collide::cli::kExitOk;
    bool first = true;
    for (const std::string& path : *files) {
      auto footage = collide::vision::Footage::open(path);
      if (!footage) {
        std::cerr << "collide info: " << footage.error().message << "\n";
        status = collide::cli::kExitBadInput;
        continue;
      }
      if (!first) std::cout << "\n";
      first = false;
      std::cout << collide::vision::describeFootage(footage->info());
    }
    return status;
  };
}

}  // namespace

COLLIDE_COMMAND(info, "What a camera file holds (Photron MRAW/CIH(X), Phantom CINE, pco B16)",
                setupInfo);
