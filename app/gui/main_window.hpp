#pragma once
// The lab GUI's main window: the rig panel (dock), and the views as tabs —
// Live, Replay (with the result card), Shots (the browser) and Campaign —
// plus the calibration dialog (Tools menu). Device and input errors appear in
// a message bar (what happened, what to do), never as a crash or a frozen
// window: every device call runs on the rig's control thread (RigWorker),
// every analysis on the thread pool. Window geometry, dock layout, the open
// tab and the folders persist between runs (QSettings).
#include <QMainWindow>
#include <QString>
#include <QStringList>
#include <QThreadPool>

#include "app/gui/rig_worker.hpp"
#include "app/gui/shot_analysis_service.hpp"

class QVBoxLayout;
class QLabel;
class QTabWidget;
class QProgressDialog;
class QFontMetrics;
class QFrame;
class QPushButton;

namespace collide::gui {

/// A message's first sentence (up to the first ". "), or all of it.
QString firstSentence(const QString& message);
/// What the message bar says when a campaign ends: the summary's first
/// sentence (planned, fired, saved) and, when the summary says more, where
/// the rest is (the Campaign view shows the whole summary).
QString campaignHeadline(const QString& summary);
/// What the status bar shows of a message (the message bar shows it whole):
/// its first sentence, cut at a word boundary with an ellipsis when wider
/// than `width_px` in `metrics`.
QString statusBarLine(const QString& message, const QFontMetrics& metrics, int width_px);

class RigPanel;
class LiveView;
class ReplayView;
class ShotBrowser;
class CampaignView;
class PlanDialog;

struct MainWindowOptions {
  QString rig_profile;  ///< profile to load; empty: the last one used, else the built-in sim
  QString shots_dir;    ///< where shots are saved; empty: the last one used, else ./shots
  bool restore_settings = true;  ///< read and write QSettings (tests turn it off)
};

class MainWindow : public QMainWindow {
  Q_OBJECT
 public:
  explicit MainWindow(MainWindowOptions options = {}, QWidget* parent = nullptr);
  ~MainWindow() override;

  RigPanel* rigPanel() const { return rig_panel_; }
  LiveView* liveView() const { return live_view_; }
  ReplayView* replayView() const { return replay_view_; }
  ShotBrowser* shotBrowser() const { return shot_browser_; }
  CampaignView* campaignView() const { return campaign_view_; }
  QTabWidget* tabs() const { return tabs_; }
  RigWorker* rigWorker() const { return worker_; }
  AnalysisRunner* analysisRunner() const { return runner_; }

  QString shotsDir() const { return shots_dir_; }
  void setShotsDir(const QString& dir);
  void loadProfile(const QString& path);
  ProfilePtr profile() const { return profile_; }
  /// The last shot fired from this window (null before the first).
  ShotPtr lastShot() const { return last_shot_; }
  /// Messages shown in the message bar so far, oldest first.
  const QStringList& messages() const { return messages_; }
  /// How a message is shown: red (error), amber (warning: something is
  /// missing or was not done) or green (done as asked).
  enum class MessageKind { Error, Warning, Info };
  /// What a message is about: the bar hides it by itself once that is fixed
  /// (a profile loads, the shot folder is usable, the rig is armed and settled).
  enum class MessageTopic { Other, Profile, ShotsDir, Arming };
  void showMessage(const QString& message, MessageKind kind = MessageKind::Error,
                   MessageTopic topic = MessageTopic::Other);
  /// The message bar is showing (false once dismissed or stale).
  bool messageShown() const;
  MessageKind lastMessageKind() const { return last_kind_; }
  /// The shot folder exists (or was created), is a folder and can be written.
  bool shotsDirUsable() const { return shots_usable_; }
  /// A fired shot that could not be saved (null if none): "Save elsewhere" offers it.
  ShotPtr unsavedShot() const { return unsaved_shot_; }
  /// Saves the unsaved shot into `dir` (on a worker; the message bar says how it went).
  void saveUnsavedShotTo(const QString& dir);

  void openCalibrationDialog();
  /// Tools > Plan a shot: the dialog (non-modal; null without a profile).
  PlanDialog* openPlanDialog();
  /// Opens a recording in Replay and analyses it (results not stored): a shot
  /// file (.h5) or footage from another program (Photron .mraw/.cih/.cihx,
  /// Phantom .cine, pco .b16, a video). Read on a worker; recordingOpened says
  /// how it went.
  void openRecording(const QString& path);

 signals:
  /// A recording opened with openRecording is in Replay (error empty), or why not.
  void recordingOpened(QString path, QString error);
  /// A shot's analysis finished (or failed) and is on the result card.
  void shotAnalysed(QString shot_id, bool ok);
  /// A shot's results were written into its file and catalog row (or not: `error`).
  void resultsStored(QString shot_id, QString error);

 protected:
  void closeEvent(QCloseEvent* event) override;

 private:
  // The constructor's parts.
  void addMessageBar(QVBoxLayout* layout);
  void addViews(QVBoxLayout* layout);
  void addRigDock();
  void buildMenus();
  void connectRigPanel();
  void connectWorker();
  void connectCampaign();
  void connectAnalysis();
  void connectBrowser();
  void restoreSettings();
  void saveSettings();
  void onShotFired(ShotPtr shot, QString file, QString save_error);
  void onAnalysed(ShotPtr shot, AnalysisPtr analysis, QString tag, QString file,
                  QString results_json);
  void onAnalysisFailed(ShotPtr shot, QString message, QString tag, QString file);
  void showShot(ShotPtr shot);
  void reanalyse(const QStringList& files);
  void startCampaign(int shots, quint64 seed, double angle_min, double angle_max);
  void startAdaptiveCampaign(int budget, quint64 seed, double angle_min, double angle_max,
                             double target_sigma_mu, double target_sigma_beta0);
  /// The shot folder checked and the progress dialog up; false (and said
  /// why) when the folder cannot take shots.
  bool beginCampaign(int shots, const QString& title);
  /// A campaign of `shots` (or at most, adaptive) into this window's shot folder.
  app::CampaignOptions campaignOptions(int shots, quint64 seed, double angle_min,
                                       double angle_max) const;
  void onAdaptiveProgress(AdaptiveStepPtr step);
  /// Writes the results JSON into the shot's file and catalog row (worker thread).
  void storeResults(const QString& file, const std::string& id, std::string results_json);
  /// Empty if shots can be saved in `dir`, else why not (and what to do).
  static QString shotsDirProblem(const QString& dir, bool create);

  MainWindowOptions options_;
  RigWorker* worker_ = nullptr;
  AnalysisRunner* runner_ = nullptr;
  RigPanel* rig_panel_ = nullptr;
  LiveView* live_view_ = nullptr;
  ReplayView* replay_view_ = nullptr;
  ShotBrowser* shot_browser_ = nullptr;
  CampaignView* campaign_view_ = nullptr;
  QTabWidget* tabs_ = nullptr;
  QFrame* message_bar_ = nullptr;
  QLabel* message_label_ = nullptr;
  QPushButton* save_elsewhere_ = nullptr;
  MessageKind last_kind_ = MessageKind::Info;
  MessageTopic topic_ = MessageTopic::Other;
  void clearStale(MessageTopic fixed);
  bool shots_usable_ = false;
  bool campaign_running_ = false;
  ShotPtr unsaved_shot_;
  QProgressDialog* progress_ = nullptr;
  int batch_total_ = 0, batch_done_ = 0;
  QString profile_path_;
  QString replay_file_;  ///< the file of the shot in the replay view
  QThreadPool store_pool_;
  QString shots_dir_;
  ProfilePtr profile_;
  ShotPtr last_shot_;
  QStringList messages_;
  std::vector<MeasuredLaunch> launches_;
  /// Exit speeds to set once the aimed profile at `path` is loaded (a plan).
  struct PendingPlan {
    QString path;
    std::array<double, 2> speeds_m_s;
  };
  std::optional<PendingPlan> pending_plan_;  ///< measured this session, for the calibration
};

}  // namespace collide::gui
