#pragma once
// The GUI's way into the vision core: analyse a recorded shot on a worker
// thread, and turn the result into what the views need (campaign points,
// measured exit speeds). No widgets here.
#include <QFutureWatcher>
#include <QObject>
#include <QString>
#include <array>
#include <atomic>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "analysis/campaign.hpp"
#include "analysis/result.hpp"
#include "hw/rig_profile.hpp"
#include "hw/shot.hpp"
#include "vision/shot_analysis.hpp"

namespace collide::gui {

using ShotPtr = std::shared_ptr<const hw::Shot>;
using AnalysisPtr = std::shared_ptr<const vision::ShotAnalysis>;

/// A shot's analysis as the views show it, and as its file stores it.
struct AnalysedShot {
  vision::ShotAnalysis analysis;
  std::string results_json;  ///< docs/results-format.md (a wall shot's own form for a wall)
};

/// Analyses the shot as `collide analyze` does: a sphere-on-wall shot (its
/// recorded profile has a [wall]) with the wall analysis, any other with the
/// two-sphere one (app::analysisSettingsFor). Errors: the shot failed or has
/// no frames, the analysis failed (its message).
Result<AnalysedShot> analyzeShot(const hw::Shot& shot);

/// A results JSON (either form) as the views' ShotAnalysis: collision,
/// spheres and flags (no notes, no per-frame detections); nothing when it
/// does not parse or records a failed analysis.
std::optional<vision::ShotAnalysis> analysisFromResultsJson(const std::string& json);

/// Where the shot's analysis clock starts, for the result card: "the first
/// analysed frame" (two spheres) or frame 0, the trigger frame (a wall shot,
/// whose times are frame id / frame rate).
QString timeOrigin(const hw::Shot& shot);

/// The campaign fits' view of one analysed shot; nothing when the shot has no
/// usable collision (e.g. v_n >= 0).
std::optional<CampaignShot> campaignPoint(const vision::ShotAnalysis& analysis);

/// A measured launch: the regulator read-back when the valve fired (gauge kPa)
/// and the exit speed the analysis measured (m/s, the pre-impact velocity
/// along the tube axis: gravity is perpendicular to a horizontal tube, so that
/// component is the same at the muzzle as at the collision).
struct MeasuredLaunch {
  QString shot_id;
  int launcher = 0;
  double pressure_kPa = 0;
  double speed_m_s = 0;
  double speed_sigma_m_s = 0;
};

/// Both launches of an analysed shot, using the launchers' tube axes from the
/// profile the shot was fired with (shot.rig_profile_toml). Empty when that
/// profile cannot be read.
std::vector<MeasuredLaunch> measuredLaunches(
    const hw::Shot& shot, const std::array<vision::SphereKinematics, 2>& spheres);

/// The measured launches of every analysed shot in a shot folder (read from
/// the shot files' stored results, without frames). `skipped` counts analysed
/// shots whose results or profile could not be used. Errors: no catalog.
Result<std::vector<MeasuredLaunch>> measuredLaunchesInFolder(const std::string& dir,
                                                             int* skipped = nullptr);

/// The stored results of a shot (its results JSON) as an analysis without
/// per-frame data, for the result card. Nothing if it has none or they say
/// the analysis failed.
std::optional<vision::ShotAnalysis> storedAnalysis(const hw::Shot& shot);

/// Runs analyses on the global thread pool and reports back on the thread that
/// owns this object (the GUI thread). Shots are analysed in the order queued.
class AnalysisRunner : public QObject {
  Q_OBJECT
 public:
  explicit AnalysisRunner(QObject* parent = nullptr);
  ~AnalysisRunner() override;

  /// Queues `shot` for analysis; `tag` and `file` (where the shot is stored,
  /// may be empty) come back with the result.
  void analyze(ShotPtr shot, QString tag = {}, QString file = {});
  /// Queues the shot file at `path`: read (with frames) and analysed on the worker.
  void analyzeFile(QString path, QString tag = {});
  /// Drops every queued shot not yet started (the running one finishes).
  void cancelQueued();
  int pending() const { return pending_; }

 signals:
  /// `results_json`: what the shot's file should store (results-format.md).
  void analysed(collide::gui::ShotPtr shot, collide::gui::AnalysisPtr analysis, QString tag,
                QString file, QString results_json);
  /// `shot` is null when the file could not be read.
  void failed(collide::gui::ShotPtr shot, QString message, QString tag, QString file);
  /// Queue length changed (running + waiting).
  void pendingChanged(int pending);

 private:
  void startNext();
  struct Job {
    ShotPtr shot;
    QString path;  ///< where the shot is stored; read from here when `shot` is null
    QString tag;
  };
  struct Outcome {
    ShotPtr shot;
    AnalysisPtr analysis;
    QString message;
    QString results_json;
  };
  std::vector<Job> queue_;
  Job current_;
  bool running_ = false;
  int pending_ = 0;
  QFutureWatcher<Outcome> watcher_;
};

}  // namespace collide::gui

Q_DECLARE_METATYPE(collide::gui::ShotPtr)
Q_DECLARE_METATYPE(collide::gui::AnalysisPtr)
