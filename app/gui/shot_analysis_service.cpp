#include "app/gui/shot_analysis_service.hpp"

#include <QtConcurrent/QtConcurrentRun>
#include <cmath>
#include <filesystem>

#include "app/analyze.hpp"
#include "app/report/results_json.hpp"
#include "app/store/catalog.hpp"
#include "app/store/shot_file.hpp"
#include "app/wall_analyze.hpp"

namespace collide::gui {

Result<AnalysedShot> analyzeShot(const hw::Shot& shot) {
  if (shot.status != hw::ShotStatus::Ok)
    return fail("shot " + shot.id + " failed (" + shot.failure_reason +
                "): there is no burst to analyse");
  if (shot.burst.frames.empty() || shot.burst.frames.front().image.empty())
    return fail("shot " + shot.id + " has no frame images: open the shot file with its frames");
  AnalysedShot out;
  if (auto wall = app::analyzeWallShotInFull(shot)) {  // a sphere-on-wall shot
    if (!*wall) return wall->error();
    auto analysis = analysisFromResultsJson((*wall)->results_json);
    if (!analysis) return fail("shot " + shot.id + ": the wall analysis' results do not parse");
    out.analysis = std::move(*analysis);
    // The sphere's fitted paths, for the replay to draw (sphere 1).
    out.analysis.trajectory[0] = {(*wall)->analysis.before, (*wall)->analysis.after};
    out.results_json = std::move((*wall)->results_json);
    return out;
  }
  auto analysis = vision::analyzeBurst(shot.burst, app::analysisSettingsFor(shot));
  if (!analysis) return analysis.error();
  out.analysis = std::move(analysis).value();
  out.results_json = app::resultsToJson(out.analysis);
  return out;
}

std::optional<vision::ShotAnalysis> analysisFromResultsJson(const std::string& json) {
  auto r = app::parseResultsJson(json);
  if (!r || r->error) return std::nullopt;
  vision::ShotAnalysis a;
  a.pixel_size_m = r->pixel_size_m;
  a.sphere = r->sphere;
  a.collision = r->collision;
  a.quality_flags = r->quality_flags;
  return a;
}

QString timeOrigin(const hw::Shot& shot) {
  return app::wallAnalysisSettingsFor(shot) ? QObject::tr("frame 0 (the trigger frame)")
                                            : QObject::tr("the first analysed frame");
}

std::optional<CampaignShot> campaignPoint(const vision::ShotAnalysis& a) {
  const vision::CollisionProperties& c = a.collision;
  const CampaignShot s = app::campaignShotFrom(c);
  if (!(s.v_n_m_s < 0) || !std::isfinite(s.e) || !std::isfinite(s.v_s_m_s)) return std::nullopt;
  return s;
}

std::vector<MeasuredLaunch> measuredLaunches(
    const hw::Shot& shot, const std::array<vision::SphereKinematics, 2>& spheres) {
  std::vector<MeasuredLaunch> out;
  auto profile = hw::parseRigProfile(shot.rig_profile_toml, shot.id + " (rig profile)");
  if (!profile) return out;
  for (int i = 0; i < 2; ++i) {
    Vec3 axis = profile->launchers[i].direction;
    axis.z() = 0;  // trajectories before impact lie in the image plane
    if (axis.norm() == 0) continue;
    axis.normalize();
    const Estimate3& v = spheres[i].velocity_before_m_s;
    MeasuredLaunch m;
    m.shot_id = QString::fromStdString(shot.id);
    m.launcher = i;
    m.pressure_kPa = shot.launchers[i].readback_kPa;
    m.speed_m_s = v.value.dot(axis);
    m.speed_sigma_m_s =
        std::sqrt(std::pow(axis.x() * v.sigma.x(), 2) + std::pow(axis.y() * v.sigma.y(), 2));
    if (std::isfinite(m.speed_m_s) && m.speed_m_s > 0) out.push_back(m);
  }
  return out;
}

Result<std::vector<MeasuredLaunch>> measuredLaunchesInFolder(const std::string& dir, int* skipped) {
  auto catalog = app::Catalog::open(dir, app::Catalog::Mode::OpenExisting);
  if (!catalog) return catalog.error();
  app::ShotFilter ok;
  ok.status = hw::ShotStatus::Ok;
  auto rows = catalog->query(ok);
  if (!rows) return rows.error();
  std::vector<MeasuredLaunch> out;
  int bad = 0;
  for (const app::CatalogRow& row : *rows) {
    if (!row.analysed) continue;
    auto shot = app::readShot((std::filesystem::path(dir) / row.file).string(),
                              {.frames = false, .contained = true});
    if (!shot) {
      ++bad;
      continue;
    }
    auto results = app::parseResultsJson(shot->results_json);
    if (!results || results->error) {
      ++bad;
      continue;
    }
    const auto launches = measuredLaunches(*shot, results->sphere);
    if (launches.empty()) ++bad;
    out.insert(out.end(), launches.begin(), launches.end());
  }
  if (skipped) *skipped = bad;
  return out;
}

std::optional<vision::ShotAnalysis> storedAnalysis(const hw::Shot& shot) {
  if (shot.results_json.empty()) return std::nullopt;
  return analysisFromResultsJson(shot.results_json);
}

AnalysisRunner::AnalysisRunner(QObject* parent) : QObject(parent) {
  connect(&watcher_, &QFutureWatcher<Outcome>::finished, this, [this] {
    const Outcome outcome = watcher_.result();
    const Job job = current_;
    running_ = false;
    --pending_;
    if (outcome.analysis)
      emit analysed(outcome.shot, outcome.analysis, job.tag, job.path, outcome.results_json);
    else
      emit failed(outcome.shot, outcome.message, job.tag, job.path);
    emit pendingChanged(pending_);
    startNext();
  });
}

AnalysisRunner::~AnalysisRunner() {
  queue_.clear();
  watcher_.waitForFinished();  // the worker reads current_.shot
}

void AnalysisRunner::analyze(ShotPtr shot, QString tag, QString file) {
  queue_.push_back({std::move(shot), std::move(file), std::move(tag)});
  ++pending_;
  emit pendingChanged(pending_);
  startNext();
}

void AnalysisRunner::analyzeFile(QString path, QString tag) {
  queue_.push_back({nullptr, std::move(path), std::move(tag)});
  ++pending_;
  emit pendingChanged(pending_);
  startNext();
}

void AnalysisRunner::cancelQueued() {
  pending_ -= static_cast<int>(queue_.size());
  queue_.clear();
  emit pendingChanged(pending_);
}

void AnalysisRunner::startNext() {
  if (running_ || queue_.empty()) return;
  running_ = true;
  current_ = queue_.front();
  queue_.erase(queue_.begin());
  ShotPtr shot = current_.shot;
  const std::string path = current_.path.toStdString();
  watcher_.setFuture(QtConcurrent::run([shot, path]() mutable -> Outcome {
    if (!shot) {
      Result<hw::Shot> read = app::readShot(path);
      if (!read) return {nullptr, nullptr, QString::fromStdString(read.error().message)};
      shot = std::make_shared<const hw::Shot>(std::move(read).value());
    }
    Result<AnalysedShot> result = analyzeShot(*shot);
    if (!result) return {shot, nullptr, QString::fromStdString(result.error().message), {}};
    return {shot,
            std::make_shared<const vision::ShotAnalysis>(std::move(result->analysis)),
            {},
            QString::fromStdString(result->results_json)};
  }));
}

}  // namespace collide::gui
