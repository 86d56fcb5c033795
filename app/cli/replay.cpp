// `collide replay SHOT.h5... --out DIR`: recorded shots through the replay
// camera, the sequencer and the simulated devices, saved (and analysed) again.
#include "app/replay.hpp"

#include <cmath>
#include <cstdio>
#include <iostream>

#include "app/analyze.hpp"
#include "app/cli/command.hpp"
#include "app/cli/interrupt.hpp"
#include "app/report/results_json.hpp"
#include "app/store/shot_file.hpp"

namespace {

using collide::cli::kExitBadInput;
using collide::cli::kExitFailure;
using collide::cli::kExitOk;

struct Options {
  std::vector<std::string> files;
  collide::app::ReplayOptions replay;
  bool analyze = true;
};

std::string eBeta(const std::string& json) {
  auto r = collide::app::parseResultsJson(json);
  if (!r) return "unreadable results";
  if (r->error) return "analysis failed: " + *r->error;
  char buf[96];
  std::snprintf(buf, sizeof buf, "e %.4f±%.4f beta %.3f±%.3f", r->collision.e.value,
                r->collision.e.sigma, r->collision.beta.value, r->collision.beta.sigma);
  return buf;
}

int runReplay(const Options& o) {
  collide::cli::StopOnInterrupt stop;
  int failed = 0, bad = 0;
  for (std::size_t i = 0; i < o.files.size() && !stop.interrupted(); ++i) {
    auto opts = o.replay;
    opts.sequence = static_cast<int>(i);
    auto replayed = collide::app::replayShotFile(o.files[i], opts, stop.token());
    if (!replayed) {
      std::cerr << "collide replay: " << replayed.error().message << "\n";
      ++bad;
      continue;
    }
    std::cout << o.files[i] << " -> " << replayed->file << " ("
              << collide::hw::toString(replayed->shot.status) << ")\n";
    if (replayed->shot.status != collide::hw::ShotStatus::Ok) {
      std::cout << "  " << replayed->shot.failure_reason << "\n";
      ++failed;
      continue;
    }
    if (!o.analyze) continue;
    auto outcome = collide::app::analyzeShotFile(replayed->file);
    if (!outcome.analysed) {
      std::cout << "  not analysed: " << outcome.message << "\n";
      ++failed;
      continue;
    }
    std::cout << "  replayed: " << eBeta(outcome.results_json) << "\n";
    auto original = collide::app::readShot(o.files[i], {.frames = false});
    if (original && !original->results_json.empty())
      std::cout << "  recorded: " << eBeta(original->results_json) << "\n";
    if (original && original->truth)
      std::printf("  truth:    e %.4f (simulated shot)\n", original->truth->material.e);
  }
  if (bad) return kExitBadInput;
  return failed ? kExitFailure : kExitOk;
}

void setupReplay(CLI::App& sub, std::function<int()>& run) {
  auto o = std::make_shared<Options>();
  sub.add_option("files", o->files, "Recorded shot files (.h5)")
      ->required()
      ->check(CLI::ExistingFile);
  sub.add_option("--out", o->replay.out_dir, "Folder for the replayed shots")->required();
  sub.add_flag("--realtime", o->replay.realtime, "Play the frames at the recorded pace");
  sub.add_flag("!--no-analyze", o->analyze, "Only replay and save; do not analyse");
  sub.footer(
      "Each shot is fired again with the profile it was recorded with, its camera replaced\n"
      "by the replay camera and its regulator and valves by simulated ones; no hardware is\n"
      "touched. The replayed shot is saved and analysed like a live one.");
  run = [o] { return runReplay(*o); };
}

}  // namespace

COLLIDE_COMMAND(replay, "Replay recorded shots through the simulated rig and analyse them again",
                setupReplay);
