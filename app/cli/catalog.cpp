// `collide catalog rebuild DIR`: recreate a shot folder's catalog from its .h5 files.
#include "app/store/catalog.hpp"

#include <iostream>

#include "app/cli/command.hpp"

namespace {

void setupCatalog(CLI::App& sub, std::function<int()>& run) {
  sub.require_subcommand(1);
  CLI::App* rebuild = sub.add_subcommand(
      "rebuild", "Recreate DIR/catalog.sqlite from the shot files in DIR (reading no frames)");
  auto dir = std::make_shared<std::string>();
  rebuild->add_option("DIR", *dir, "Shot folder")->required();
  rebuild->footer(
      "Files that cannot be read are listed on stderr and left out; the exit status is then 1.");
  run = [=] {
    auto report = collide::app::rebuildCatalog(*dir);
    if (!report) {
      std::cerr << "collide catalog rebuild: " << report.error().message << "\n";
      return collide::cli::kExitBadInput;
    }
    for (const auto& bad : report->unreadable)
      std::cerr << "collide catalog rebuild: skipped " << bad.file << ": " << bad.message << "\n";
    for (const auto& left : report->leftovers)
      std::cerr << "collide catalog rebuild: " << left
                << " is a temporary file of a write that never finished (not a shot): "
                   "delete it\n";
    std::cout << "catalog " << *dir << "/" << collide::app::kCatalogFileName << ": "
              << report->shots << " shot" << (report->shots == 1 ? "" : "s");
    if (!report->unreadable.empty())
      std::cout << ", " << report->unreadable.size() << " unreadable file"
                << (report->unreadable.size() == 1 ? "" : "s") << " skipped";
    std::cout << "\n";
    return report->unreadable.empty() ? collide::cli::kExitOk : collide::cli::kExitFailure;
  };
}

}  // namespace

COLLIDE_COMMAND(catalog, "Maintain a shot folder's catalog (rebuild)", setupCatalog);
