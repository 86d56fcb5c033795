// `collide note DIR ID [TEXT]`: read or set the experimenter's note on a shot,
// stored in its shot file and its catalog row.
#include <iostream>

#include "app/cli/command.hpp"
#include "app/store/catalog.hpp"
#include "app/store/save.hpp"

namespace {

void setupNote(CLI::App& sub, std::function<int()>& run) {
  auto dir = std::make_shared<std::string>();
  auto id = std::make_shared<std::string>();
  auto text = std::make_shared<std::string>();
  auto clear = std::make_shared<bool>(false);
  sub.add_option("DIR", *dir, "Shot folder")->required();
  sub.add_option("ID", *id, "Shot id (as `collide shots DIR` lists it)")->required();
  auto* text_opt =
      sub.add_option("TEXT", *text, "The note (quote it); without it the note is printed");
  sub.add_flag("--clear", *clear, "Remove the note")->excludes(text_opt);
  sub.footer(
      "The note is written into the shot file (a copy renamed over it: the recorded data is never\n"
      "at risk) and its catalog row; the GUI's Shots tab shows and edits it too.");
  run = [=] {
    if (text->empty() && !*clear) {
      auto catalog = collide::app::Catalog::open(*dir, collide::app::Catalog::Mode::OpenExisting);
      if (!catalog) {
        std::cerr << "collide note: " << catalog.error().message << "\n";
        return collide::cli::kExitBadInput;
      }
      auto rows = catalog->query();
      if (!rows) {
        std::cerr << "collide note: " << rows.error().message << "\n";
        return collide::cli::kExitFailure;
      }
      for (const auto& r : *rows)
        if (r.id == *id) {
          std::cout << (r.note.empty() ? "(no note)" : r.note) << "\n";
          return collide::cli::kExitOk;
        }
      std::cerr << "collide note: no shot " << *id << " in " << *dir
                << ": list them with `collide shots " << *dir << "`\n";
      return collide::cli::kExitBadInput;
    }
    if (auto s = collide::app::saveNote(*dir, *id, *clear ? std::string() : *text); !s) {
      std::cerr << "collide note: " << s.error().message << "\n";
      return collide::cli::kExitBadInput;
    }
    std::cout << (*clear ? "removed the note of " : "noted on ") << *id << "\n";
    return collide::cli::kExitOk;
  };
}

}  // namespace

COLLIDE_COMMAND(note, "Read or set the note on a shot (stored in its file and catalog row)",
                setupNote);
