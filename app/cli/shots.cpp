// `collide shots DIR`: list a shot folder's catalog, as a table or as JSON.
#include <cmath>
#include <cstdio>
#include <ctime>
#include <iostream>
#include <nlohmann/json.hpp>

#include "app/cli/command.hpp"
#include "app/store/catalog.hpp"
#include "app/store/shot_file.hpp"

namespace {

using collide::app::CatalogRow;

std::string utcTime(std::int64_t unix_ns) {
  const std::time_t secs = static_cast<std::time_t>(unix_ns / 1000000000);
  std::tm tm{};
  gmtime_r(&secs, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

/// A number with `decimals`, or "-" for NaN / not analysed.
std::string cell(double v, int decimals) {
  if (std::isnan(v)) return "-";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}
std::string cell(const std::optional<double>& v, int decimals) {
  return v ? cell(*v, decimals) : "-";
}

nlohmann::json numberOrNull(double v) {
  return std::isnan(v) ? nlohmann::json(nullptr) : nlohmann::json(v);
}
nlohmann::json numberOrNull(const std::optional<double>& v) {
  return v ? nlohmann::json(*v) : nlohmann::json(nullptr);
}

nlohmann::json toJson(const CatalogRow& r) {
  const auto& res = r.results;
  return {
      {"id", r.id},
      {"file", r.file},
      {"wall_time_unix_ns", r.wall_time_unix_ns},
      {"wall_time_utc", utcTime(r.wall_time_unix_ns)},
      {"rig_name", r.rig_name},
      {"material", r.material},
      {"wanted_speed_m_s",
       {numberOrNull(r.wanted_speed_m_s[0]), numberOrNull(r.wanted_speed_m_s[1])}},
      {"commanded_kPa", {numberOrNull(r.commanded_kPa[0]), numberOrNull(r.commanded_kPa[1])}},
      {"readback_kPa", {numberOrNull(r.readback_kPa[0]), numberOrNull(r.readback_kPa[1])}},
      {"status", collide::hw::toString(r.status)},
      {"failure_reason", r.failure_reason},
      {"frames", r.frames},
      {"analysed", r.analysed},
      {"e", numberOrNull(res.e)},
      {"beta", numberOrNull(res.beta)},
      {"f", numberOrNull(res.f)},
      {"gamma_deg", numberOrNull(res.gamma_deg)},
      {"vn_m_s", numberOrNull(res.vn_m_s)},
      {"vs_m_s", numberOrNull(res.vs_m_s)},
      {"quality_flags", res.quality_flags},
      {"note", r.note},
  };
}

void printTable(const std::vector<CatalogRow>& rows) {
  std::printf("%-22s %-20s %-6s %-12s %-13s %-13s %-11s %6s %6s %6s %6s %9s  %s\n", "id",
              "time (UTC)", "status", "material", "kPa 0 cmd/rb", "kPa 1 cmd/rb", "v m/s 0/1",
              "frames", "e", "beta", "f", "gamma_deg", "flags / failure; note");
  for (const auto& r : rows) {
    const std::string kPa0 = cell(r.commanded_kPa[0], 1) + "/" + cell(r.readback_kPa[0], 1);
    const std::string kPa1 = cell(r.commanded_kPa[1], 1) + "/" + cell(r.readback_kPa[1], 1);
    const std::string speeds =
        cell(r.wanted_speed_m_s[0], 2) + "/" + cell(r.wanted_speed_m_s[1], 2);
    std::string note = r.status == collide::hw::ShotStatus::Failed
                           ? r.failure_reason
                           : collide::app::joinFlags(r.results.quality_flags);
    if (!r.note.empty()) note += (note.empty() ? "note: " : "; note: ") + r.note;
    std::printf("%-22s %-20s %-6s %-12s %-13s %-13s %-11s %6lld %6s %6s %6s %9s  %s\n",
                r.id.c_str(), utcTime(r.wall_time_unix_ns).c_str(), collide::hw::toString(r.status),
                r.material.c_str(), kPa0.c_str(), kPa1.c_str(), speeds.c_str(),
                static_cast<long long>(r.frames), cell(r.results.e, 3).c_str(),
                cell(r.results.beta, 3).c_str(), cell(r.results.f, 3).c_str(),
                cell(r.results.gamma_deg, 1).c_str(), note.c_str());
  }
  std::printf("%zu shot%s\n", rows.size(), rows.size() == 1 ? "" : "s");
}

void setupShots(CLI::App& sub, std::function<int()>& run) {
  auto dir = std::make_shared<std::string>();
  auto material = std::make_shared<std::string>();
  auto status = std::make_shared<std::string>();
  auto json = std::make_shared<bool>(false);
  sub.add_option("DIR", *dir, "Shot folder (holds catalog.sqlite and the .h5 files)")->required();
  sub.add_option("--material", *material, "Only shots of this material (as in the rig profile)");
  sub.add_option("--status", *status, "Only shots with this status")
      ->check(CLI::IsMember({"ok", "failed"}));
  sub.add_flag("--json", *json, "Print a JSON array (every column) instead of a table");
  sub.footer(
      "Launcher columns are per launcher 0/1: commanded/read-back pressure (kPa) and wanted exit\n"
      "speed (m/s, '-' when the pressure was set directly). Result columns show '-' until the\n"
      "shot is analysed.");
  run = [=] {
    auto catalog = collide::app::Catalog::open(*dir, collide::app::Catalog::Mode::OpenExisting);
    if (!catalog) {
      std::cerr << "collide shots: " << catalog.error().message << "\n";
      return collide::cli::kExitBadInput;
    }
    collide::app::ShotFilter filter;
    if (!material->empty()) filter.material = *material;
    if (!status->empty()) filter.status = collide::app::parseShotStatus(*status);
    auto rows = catalog->query(filter);
    if (!rows) {
      std::cerr << "collide shots: " << rows.error().message << "\n";
      return collide::cli::kExitFailure;
    }
    // The catalog is an index: say when it no longer matches the files (an
    // empty or stale catalog would otherwise show "0 shots" for a full folder).
    if (auto contents = collide::app::listShotFolder(*dir)) {
      auto all = filter.material || filter.status ? catalog->query() : rows;
      if (all && all->size() != contents->shot_files.size())
        std::cerr << "collide shots: the catalog lists " << all->size() << " shot"
                  << (all->size() == 1 ? "" : "s") << " but " << *dir << " holds "
                  << contents->shot_files.size() << " shot file"
                  << (contents->shot_files.size() == 1 ? "" : "s")
                  << ": run `collide catalog rebuild " << *dir << "`\n";
    }
    if (*json) {
      nlohmann::json out = nlohmann::json::array();
      for (const auto& r : *rows) out.push_back(toJson(r));
      std::cout << out.dump(2) << "\n";
    } else {
      printTable(*rows);
    }
    return collide::cli::kExitOk;
  };
}

}  // namespace

COLLIDE_COMMAND(shots, "List the shots in a shot folder's catalog (table or --json)", setupShots);
