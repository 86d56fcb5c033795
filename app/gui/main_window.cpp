#include "app/gui/main_window.hpp"

#include <QApplication>
#include <QCloseEvent>
#include <QDir>
#include <QDockWidget>
#include <QFileDialog>
#include <QFileInfo>
#include <QFontMetrics>
#include <QFrame>
#include <QFutureWatcher>
#include <QHBoxLayout>
#include <QLabel>
#include <QMenuBar>
#include <QMessageBox>
#include <QProgressDialog>
#include <QPushButton>
#include <QSettings>
#include <QStatusBar>
#include <QTabWidget>
#include <QTemporaryFile>
#include <QVBoxLayout>
#include <QtConcurrent/QtConcurrentRun>
#include <algorithm>

#include "app/footage_shot.hpp"
#include "app/gui/calibration_dialog.hpp"
#include "app/gui/campaign_view.hpp"
#include "app/gui/live_view.hpp"
#include "app/gui/plan_dialog.hpp"
#include "app/gui/replay_view.hpp"
#include "app/gui/rig_panel.hpp"
#include "app/gui/shot_browser.hpp"
#include "app/report/results_json.hpp"
#include "app/store/save.hpp"
#include "app/store/shot_file.hpp"

namespace collide::gui {
namespace {

QString qs(const std::string& s) {
  return QString::fromStdString(s);
}

}  // namespace

QString firstSentence(const QString& message) {
  // Decimal points are not followed by a space.
  const qsizetype stop = message.indexOf(". ");
  return stop > 0 ? message.left(stop + 1) : message;
}

QString campaignHeadline(const QString& summary) {
  const QString first = firstSentence(summary);
  if (first.size() == summary.size()) return summary;
  return first + ' ' +
         QObject::tr(
             "The whole report (what was not fired or failed, and why) is in the Campaign view.");
}

QString statusBarLine(const QString& message, const QFontMetrics& metrics, int width_px) {
  const QString line = firstSentence(message);
  if (metrics.horizontalAdvance(line) <= width_px) return line;
  // Whole words that fit, then an ellipsis: never cut mid-word.
  const QString ellipsis = QString::fromUtf8("…");
  QString out;
  for (const QString& word : line.split(' ')) {
    const QString next = out.isEmpty() ? word : out + ' ' + word;
    if (metrics.horizontalAdvance(next + ellipsis) > width_px) break;
    out = next;
  }
  return out.isEmpty() ? metrics.elidedText(line, Qt::ElideRight, width_px) : out + ellipsis;
}

MainWindow::MainWindow(MainWindowOptions options, QWidget* parent)
    : QMainWindow(parent), options_(std::move(options)) {
  setObjectName("main_window");
  setWindowTitle(tr("Collide"));
  qRegisterMetaType<ShotPtr>();
  qRegisterMetaType<AnalysisPtr>();
  worker_ = new RigWorker;
  runner_ = new AnalysisRunner(this);
  store_pool_.setMaxThreadCount(1);  // one shot file rewritten at a time

  auto* central = new QWidget;
  auto* layout = new QVBoxLayout(central);
  layout->setContentsMargins(4, 4, 4, 4);
  addMessageBar(layout);
  addViews(layout);
  setCentralWidget(central);
  addRigDock();
  buildMenus();
  connectRigPanel();
  connectWorker();
  connectCampaign();
  connectAnalysis();
  connectBrowser();
  if (options_.restore_settings) restoreSettings();
  if (!options_.shots_dir.isEmpty()) shots_dir_ = options_.shots_dir;
  if (shots_dir_.isEmpty()) shots_dir_ = QDir::current().filePath("shots");
  setShotsDir(shots_dir_);
  QString profile = options_.rig_profile.isEmpty() ? profile_path_ : options_.rig_profile;
  loadProfile(profile);
}

// Messages that need reading (errors, warnings, a shot not saved), above the views.
void MainWindow::addMessageBar(QVBoxLayout* layout) {
  message_bar_ = new QFrame;
  message_bar_->setObjectName("message_bar");
  message_bar_->setFrameShape(QFrame::StyledPanel);
  auto* mb = new QHBoxLayout(message_bar_);
  message_label_ = new QLabel;
  message_label_->setObjectName("message_label");
  message_label_->setWordWrap(true);
  message_label_->setTextInteractionFlags(Qt::TextSelectableByMouse);
  save_elsewhere_ = new QPushButton(tr("Save the shot elsewhere..."));
  save_elsewhere_->setObjectName("save_elsewhere");
  save_elsewhere_->hide();
  connect(save_elsewhere_, &QPushButton::clicked, this, [this] {
    const QString dir = QFileDialog::getExistingDirectory(this, tr("Save the shot into"));
    if (!dir.isEmpty()) saveUnsavedShotTo(dir);
  });
  auto* dismiss = new QPushButton(tr("Dismiss"));
  dismiss->setObjectName("dismiss_message");
  mb->addWidget(message_label_, 1);
  mb->addWidget(save_elsewhere_);
  mb->addWidget(dismiss);
  message_bar_->hide();
  connect(dismiss, &QPushButton::clicked, message_bar_, &QWidget::hide);
  layout->addWidget(message_bar_);
}

void MainWindow::addViews(QVBoxLayout* layout) {
  tabs_ = new QTabWidget;
  tabs_->setObjectName("views");
  live_view_ = new LiveView;
  live_view_->setDetector(&detectSpheresAndDots);
  replay_view_ = new ReplayView;
  shot_browser_ = new ShotBrowser;
  campaign_view_ = new CampaignView;
  tabs_->addTab(live_view_, tr("Live"));
  tabs_->addTab(replay_view_, tr("Replay"));
  tabs_->addTab(shot_browser_, tr("Shots"));
  tabs_->addTab(campaign_view_, tr("Campaign"));
  layout->addWidget(tabs_, 1);
}

void MainWindow::addRigDock() {
  // The panel scrolls its settings itself and keeps its action bar (Arm,
  // Fire, Cancel, the state) outside the scrolling part, always on screen.
  rig_panel_ = new RigPanel;
  rig_panel_->setMinimumWidth(500);
  auto* dock = new QDockWidget(tr("Rig"));
  dock->setObjectName("rig_dock");
  dock->setWidget(rig_panel_);
  dock->setFeatures(QDockWidget::DockWidgetMovable | QDockWidget::DockWidgetFloatable);
  addDockWidget(Qt::LeftDockWidgetArea, dock);
}

// Rig panel -> control thread.
void MainWindow::connectRigPanel() {
  // Rig panel -> control thread.
  connect(rig_panel_, &RigPanel::armRequested, this, [this](std::array<double, 2> v) {
    // A shot that cannot be saved should not be fired: check before the lines
    // are pressurised (the folder may have gone since it was chosen).
    if (const QString problem = shotsDirProblem(shots_dir_, false); !problem.isEmpty()) {
      shots_usable_ = false;
      rig_panel_->setShotsDir(shots_dir_, false);
      showMessage(tr("Not armed: %1").arg(problem), MessageKind::Error, MessageTopic::ShotsDir);
      return;
    }
    worker_->requestArm(v);
  });
  connect(rig_panel_, &RigPanel::inputRefused, this, [this](QString m) { showMessage(m); });
  connect(rig_panel_, &RigPanel::disarmRequested, this, [this] { worker_->requestDisarm(); });
  connect(rig_panel_, &RigPanel::fireRequested, this, [this](std::array<double, 2> v) {
    replay_view_->resultCard()->setMessage({}, tr("firing..."));
    worker_->requestFire(v, shots_dir_);
  });
  connect(rig_panel_, &RigPanel::cancelRequested, this, [this] { worker_->requestCancel(); });
  connect(rig_panel_, &RigPanel::reconnectRequested, this, [this] {
    statusBar()->showMessage(tr("Reconnecting the lost devices..."), 5000);
    worker_->requestReconnect();
  });
  connect(rig_panel_, &RigPanel::burstSettingsRequested, this, [this](BurstSettings b) {
    worker_->requestBurstSettings(b.pre_trigger_frames, b.post_trigger_frames, b.fps,
                                  b.exposure_us);
  });
}

// Control thread -> views.
void MainWindow::connectWorker() {
  // Control thread -> views.
  connect(worker_, &RigWorker::profileLoaded, this, [this](ProfilePtr profile, CameraPtr camera) {
    profile_ = profile;
    rig_panel_->setProfile(profile);
    // A plan's aimed profile: its exit speeds go into the launchers now.
    if (pending_plan_ && QFileInfo(qs(profile->source)) == QFileInfo(pending_plan_->path)) {
      for (int i = 0; i < 2; ++i) rig_panel_->setWantedSpeed(i, pending_plan_->speeds_m_s[i]);
      showMessage(tr("Planned shot loaded from %1: exit speeds %2 and %3 m/s set; arm when ready")
                      .arg(pending_plan_->path)
                      .arg(pending_plan_->speeds_m_s[0], 0, 'f', 3)
                      .arg(pending_plan_->speeds_m_s[1], 0, 'f', 3),
                  MessageKind::Info);
      pending_plan_.reset();
    }
    live_view_->setCamera(camera);
    // A message about an earlier profile or rig is stale now.
    if (camera) clearStale(MessageTopic::Profile);
    statusBar()->showMessage(tr("Rig profile %1 loaded").arg(qs(profile->source)), 5000);
  });
  connect(worker_, &RigWorker::status, rig_panel_, &RigPanel::setStatus);
  connect(worker_, &RigWorker::status, live_view_, &LiveView::setRigStatus);
  connect(live_view_, &LiveView::cameraSettingsRequested, this,
          [this](double fps, double exposure_us, double gain_db) {
            worker_->requestCameraSettings(fps, exposure_us, gain_db);
          });
  connect(live_view_, &LiveView::inputRefused, this, [this](QString m) { showMessage(m); });
  connect(worker_, &RigWorker::error, this, [this](QString m) {
    const MessageTopic topic = m.startsWith(tr("Rig profile not loaded")) ||
                                       m.startsWith(tr("The rig")) || m.startsWith(tr("No rig"))
                                   ? MessageTopic::Profile
                               : m.startsWith(tr("Pressure did not settle")) ||
                                       m.startsWith(tr("Cannot arm")) ||
                                       m.startsWith(tr("Not ready to fire"))
                                   ? MessageTopic::Arming
                                   : MessageTopic::Other;
    showMessage(m, MessageKind::Error, topic);
    // Refused camera settings: the Live controls go back to what the camera runs with.
    if (m.startsWith(tr("Camera settings not applied"))) live_view_->revertCameraControls();
  });
  connect(worker_, &RigWorker::status, this, [this](const RigStatus& s) {
    if (s.armed && s.settled) clearStale(MessageTopic::Arming);
  });
  connect(worker_, &RigWorker::shotStep, this, [this](QString step) {
    rig_panel_->setStep(step);
    statusBar()->showMessage(step, 3000);
  });
  connect(worker_, &RigWorker::shotFired, this, &MainWindow::onShotFired);
  connect(worker_, &RigWorker::reconnectFinished, this, [this](bool ok, QString message) {
    rig_panel_->reconnectFinished(ok, message);
    showMessage(message, ok ? MessageKind::Info : MessageKind::Error);
  });
}

// A campaign's progress and end, from the control thread.
void MainWindow::connectCampaign() {
  connect(worker_, &RigWorker::campaignProgress, this, [this](int done, int total, ShotPtr shot) {
    if (progress_) {
      progress_->setMaximum(total);
      progress_->setValue(done);
      progress_->setLabelText(tr("Shot %1 of %2 fired (%3); analysing as they come")
                                  .arg(done)
                                  .arg(total)
                                  .arg(qs(shot->id)));
    }
    // Analysed from its file (saved before this signal), so a campaign that
    // fires faster than the analysis keeps file names waiting, not bursts.
    if (shot->status == hw::ShotStatus::Ok)
      runner_->analyzeFile(QDir(shots_dir_).filePath(qs(app::shotFileName(shot->id))), "campaign");
    shot_browser_->refresh();
  });
  connect(worker_, &RigWorker::campaignFinished, this,
          [this](QString summary, bool cancelled, bool complete) {
            campaign_running_ = false;
            campaign_view_->setCampaignRunning(false);
            if (progress_) progress_->reset();
            // Anything short of every planned shot fired, saved and ok is a
            // warning. The whole summary (what is missing and why) goes into
            // the Campaign view; the message bar carries its first sentence.
            showMessage(campaignHeadline(summary),
                        complete && !cancelled ? MessageKind::Info : MessageKind::Warning,
                        summary.startsWith(tr("Campaign not started: no rig"))
                            ? MessageTopic::Profile
                            : MessageTopic::Other);
            campaign_view_->setReport(summary, !complete || cancelled);
            shot_browser_->refresh();
            campaign_view_->refresh();  // failed shots are in the folder too
          });
}

void MainWindow::connectAnalysis() {
  // Analysis.
  connect(runner_, &AnalysisRunner::analysed, this, &MainWindow::onAnalysed);
  connect(runner_, &AnalysisRunner::failed, this, &MainWindow::onAnalysisFailed);
  connect(replay_view_, &ReplayView::reanalyseRequested, this, [this](ShotPtr shot) {
    replay_view_->resultCard()->setMessage(qs(shot->id), tr("analysing..."));
    runner_->analyze(shot, "replay", replay_file_);
  });
}

// Browser and campaign views.
void MainWindow::connectBrowser() {
  // Browser and campaign.
  connect(shot_browser_, &ShotBrowser::shotOpened, this, [this](ShotPtr shot, QString file) {
    showShot(shot);
    replay_file_ = file;
    // Stored results go on the card at once; the analysis runs again for the
    // overlays (and is stored only if the shot had none).
    if (auto stored = storedAnalysis(*shot)) {
      replay_view_->resultCard()->setAnalysis(
          qs(shot->id), std::make_shared<const vision::ShotAnalysis>(std::move(*stored)),
          timeOrigin(*shot));
      runner_->analyze(shot, "overlay", file);
    } else {
      replay_view_->resultCard()->setMessage(qs(shot->id), tr("analysing..."));
      runner_->analyze(shot, "replay", file);
    }
  });
  connect(shot_browser_, &ShotBrowser::reanalyseRequested, this, &MainWindow::reanalyse);
  connect(shot_browser_, &ShotBrowser::error, this, [this](QString m) { showMessage(m); });
  connect(campaign_view_, &CampaignView::campaignRequested, this, &MainWindow::startCampaign);
  connect(campaign_view_, &CampaignView::adaptiveCampaignRequested, this,
          &MainWindow::startAdaptiveCampaign);
  connect(worker_, &RigWorker::adaptiveProgress, this, &MainWindow::onAdaptiveProgress);
  connect(campaign_view_, &CampaignView::cancelRequested, this,
          [this] { worker_->requestCancel(); });
}

MainWindow::~MainWindow() {
  store_pool_.waitForDone();  // never leave a results write half-way
  delete worker_;             // shuts the rig down safely on its own thread, then joins it
}

void MainWindow::buildMenus() {
  QMenu* file = menuBar()->addMenu(tr("&File"));
  file->addAction(tr("&Open rig profile..."), QKeySequence::Open, this, [this] {
    const QString path = QFileDialog::getOpenFileName(this, tr("Rig profile"), profile_path_,
                                                      tr("Rig profiles (*.toml)"));
    if (!path.isEmpty()) loadProfile(path);
  });
  file->addAction(
      tr("Open shot or &footage..."), QKeySequence(Qt::CTRL | Qt::SHIFT | Qt::Key_O), this, [this] {
        const QString path = QFileDialog::getOpenFileName(
            this, tr("Shot file or camera footage"), shots_dir_,
            tr("Shots and footage (*.h5 *.mraw *.cih *.cihx *.cine *.b16 *.avi *.mp4 *.mkv);;"
               "All files (*)"));
        if (!path.isEmpty()) openRecording(path);
      });
  file->addAction(tr("&Shot folder..."), this, [this] {
    const QString dir = QFileDialog::getExistingDirectory(this, tr("Shot folder"), shots_dir_);
    if (!dir.isEmpty()) setShotsDir(dir);
  });
  file->addSeparator();
  file->addAction(tr("&Quit"), this, &QWidget::close);
  QMenu* tools = menuBar()->addMenu(tr("&Tools"));
  tools->addAction(tr("&Launch calibration..."), this, &MainWindow::openCalibrationDialog);
  tools->addAction(tr("&Plan a shot..."), QKeySequence(Qt::CTRL | Qt::Key_P), this,
                   [this] { openPlanDialog(); });
}

QString MainWindow::shotsDirProblem(const QString& dir, bool create) {
  const QFileInfo info(dir);
  if (dir.isEmpty()) return tr("no shot folder is set: choose one (File > Shot folder)");
  if (info.exists() && !info.isDir())
    return tr("%1 is a file, not a folder: choose a shot folder (File > Shot folder)").arg(dir);
  if (!info.exists()) {
    if (!create)
      return tr("the shot folder %1 does not exist (any more): choose a shot folder (File > Shot "
                "folder)")
          .arg(dir);
    // A typo in a path usually shows in its parent too: only a new last
    // component is created.
    if (!info.absoluteDir().exists())
      return tr("neither %1 nor its parent folder %2 exists: check the path for a typo, or "
                "choose a shot folder (File > Shot folder)")
          .arg(dir, info.absolutePath());
    if (!QDir().mkdir(info.absoluteFilePath()))
      return tr("cannot create the shot folder %1: choose another (File > Shot folder)").arg(dir);
  }
  QTemporaryFile probe(QDir(dir).filePath(".collide-write-check-XXXXXX"));
  if (!probe.open())
    return tr("cannot write into %1 (%2): choose a shot folder you can write to (File > Shot "
              "folder)")
        .arg(dir, probe.errorString());
  return {};
}

void MainWindow::setShotsDir(const QString& dir) {
  shots_dir_ = dir;
  const bool existed = QFileInfo::exists(dir);
  const QString problem = shotsDirProblem(dir, true);
  shots_usable_ = problem.isEmpty();
  rig_panel_->setShotsDir(QFileInfo(dir).absoluteFilePath(), shots_usable_,
                          shots_usable_ && !existed);
  if (!shots_usable_) {
    showMessage(
        tr("Shots cannot be saved: %1. Arm and Fire stay disabled until then.").arg(problem),
        MessageKind::Error, MessageTopic::ShotsDir);
    return;
  }
  shot_browser_->setFolder(dir);
  campaign_view_->setFolder(dir);
  clearStale(MessageTopic::ShotsDir);  // an earlier folder's problem is stale now
  statusBar()->showMessage(tr("Shots are saved in %1").arg(dir), 5000);
}

void MainWindow::saveUnsavedShotTo(const QString& dir) {
  if (!unsaved_shot_) return;
  if (const QString problem = shotsDirProblem(dir, false); !problem.isEmpty()) {
    showMessage(tr("Shot not saved: %1").arg(problem));
    return;
  }
  ShotPtr shot = unsaved_shot_;
  auto* watcher = new QFutureWatcher<QString>(this);
  connect(watcher, &QFutureWatcher<QString>::finished, this, [this, watcher, shot, dir] {
    const QString result = watcher->result();
    watcher->deleteLater();
    if (result.startsWith('!')) {
      showMessage(tr("Shot %1 not saved in %2: %3").arg(qs(shot->id), dir, result.mid(1)));
      return;
    }
    if (unsaved_shot_ == shot) unsaved_shot_.reset();
    save_elsewhere_->hide();
    if (replay_view_->shot() == shot) replay_file_ = QDir(dir).filePath(result);
    showMessage(tr("Shot %1 saved as %2").arg(qs(shot->id), QDir(dir).filePath(result)),
                MessageKind::Info);
  });
  watcher->setFuture(QtConcurrent::run(&store_pool_, [shot, d = dir.toStdString()]() -> QString {
    auto saved = app::saveShot(d, *shot);
    if (!saved) return "!" + QString::fromStdString(saved.error().message);
    return QString::fromStdString(app::shotFileName(*saved));
  }));
}

void MainWindow::loadProfile(const QString& path) {
  profile_path_ = path;
  worker_->requestLoadProfile(path);
}

void MainWindow::clearStale(MessageTopic fixed) {
  if (topic_ == fixed && fixed != MessageTopic::Other) message_bar_->hide();
}

bool MainWindow::messageShown() const {
  return message_bar_->isVisible();
}

void MainWindow::showMessage(const QString& message, MessageKind kind, MessageTopic topic) {
  messages_ << message;
  last_kind_ = kind;
  topic_ = topic;
  message_label_->setText(message);
  message_bar_->setStyleSheet(kind == MessageKind::Error ? "#message_bar { background: #fbe3e0; }"
                              : kind == MessageKind::Warning
                                  ? "#message_bar { background: #fff0c2; }"
                                  : "#message_bar { background: #e3f1e0; }");
  save_elsewhere_->setVisible(unsaved_shot_ != nullptr && kind == MessageKind::Error);
  message_bar_->show();
  // The message bar shows the whole text; the status bar a line of it that fits.
  const int line_px =
      std::max(200, (statusBar()->isVisible() ? statusBar()->width() : this->width()) - 24);
  statusBar()->showMessage(statusBarLine(message, statusBar()->fontMetrics(), line_px), 8000);
}

void MainWindow::showShot(ShotPtr shot) {
  replay_view_->setShot(shot);
  tabs_->setCurrentWidget(replay_view_);
}

void MainWindow::onShotFired(ShotPtr shot, QString file, QString save_error) {
  last_shot_ = shot;
  showShot(shot);
  replay_file_ = file;
  unsaved_shot_.reset();
  save_elsewhere_->hide();
  if (!save_error.isEmpty()) {
    unsaved_shot_ = shot;  // kept in memory: "Save the shot elsewhere..." offers it
    showMessage(tr("Shot %1 was fired but not saved: %2. It is kept until the next shot: save it "
                   "elsewhere, and choose a shot folder you can write to.")
                    .arg(qs(shot->id), save_error));
  }
  if (shot->status == hw::ShotStatus::Failed) {
    showMessage(tr("Shot %1 failed: %2").arg(qs(shot->id), qs(shot->failure_reason)));
    replay_view_->resultCard()->setMessage(qs(shot->id),
                                           tr("the shot failed: %1").arg(qs(shot->failure_reason)));
    emit shotAnalysed(qs(shot->id), false);
  } else {
    replay_view_->resultCard()->setMessage(qs(shot->id), tr("analysing..."));
    runner_->analyze(shot, "fired", file);
  }
  shot_browser_->refresh();
}

void MainWindow::onAnalysed(ShotPtr shot, AnalysisPtr analysis, QString tag, QString file,
                            QString results_json) {
  if (tag == "batch" && progress_) progress_->setValue(++batch_done_);
  if (tag != "overlay") storeResults(file, shot->id, results_json.toStdString());
  std::erase_if(launches_, [&](const MeasuredLaunch& m) { return m.shot_id == qs(shot->id); });
  for (MeasuredLaunch& m : measuredLaunches(*shot, analysis->sphere)) launches_.push_back(m);
  if (replay_view_->shot() && replay_view_->shot()->id == shot->id) {
    replay_view_->setAnalysis(analysis);
    replay_view_->resultCard()->setAnalysis(qs(shot->id), analysis, timeOrigin(*shot));
  }
  emit shotAnalysed(qs(shot->id), true);
}

void MainWindow::onAnalysisFailed(ShotPtr shot, QString message, QString tag, QString file) {
  if (tag == "batch" && progress_) progress_->setValue(++batch_done_);
  const QString id = shot ? qs(shot->id) : QString();
  // A failed analysis is a result too: the catalog shows why.
  if (shot && shot->status == hw::ShotStatus::Ok && tag != "overlay")
    storeResults(file, shot->id, app::failedResultsJson(message.toStdString()));
  if (shot && replay_view_->shot() && replay_view_->shot()->id == shot->id && tag != "overlay")
    replay_view_->resultCard()->setMessage(id, message);
  if (tag != "fired" && tag != "replay") statusBar()->showMessage(message, 8000);
  emit shotAnalysed(id, false);
}

PlanDialog* MainWindow::openPlanDialog() {
  if (!profile_) {
    showMessage(tr("Open a rig profile first (File > Open rig profile): the plan needs its "
                   "launchers and calibration"),
                MessageKind::Warning, MessageTopic::Profile);
    return nullptr;
  }
  auto* dialog = new PlanDialog(profile_, profile_path_, this);
  dialog->setAttribute(Qt::WA_DeleteOnClose);
  connect(dialog, &PlanDialog::planApplied, this,
          [this](QString path, std::array<double, 2> speeds) {
            pending_plan_ = PendingPlan{path, speeds};
            loadProfile(path);
          });
  dialog->show();
  return dialog;
}

void MainWindow::openRecording(const QString& path) {
  app::FootageShotOptions options;
  if (profile_) options.diameter_m = profile_->spheres.diameter_m;
  const bool shot_file = path.endsWith(".h5", Qt::CaseInsensitive);
  auto* watcher = new QFutureWatcher<std::pair<ShotPtr, QString>>(this);
  connect(watcher, &QFutureWatcher<std::pair<ShotPtr, QString>>::finished, this,
          [this, watcher, path, shot_file, options] {
            auto [shot, error] = watcher->result();
            watcher->deleteLater();
            QApplication::restoreOverrideCursor();
            if (!shot) {
              showMessage(tr("Could not open %1: %2").arg(path, error));
              emit recordingOpened(path, error);
              return;
            }
            showShot(shot);
            replay_file_ = shot_file ? path : QString();
            replay_view_->resultCard()->setMessage(qs(shot->id), tr("analysing..."));
            // Footage has no shot file: its results are shown, not stored.
            runner_->analyze(shot, shot_file ? "replay" : "footage", replay_file_);
            if (!shot_file)
              showMessage(tr("%1: %2 frames at %3 frames/s; spheres taken as %4 and %5 mm across "
                             "(from %6)")
                              .arg(path)
                              .arg(shot->burst.frames.size())
                              .arg(shot->burst.fps, 0, 'g', 6)
                              .arg(options.diameter_m[0] * 1e3, 0, 'f', 2)
                              .arg(options.diameter_m[1] * 1e3, 0, 'f', 2)
                              .arg(profile_ ? tr("the rig profile") : tr("the default, 25.4 mm")),
                          MessageKind::Info);
            emit recordingOpened(path, {});
          });
  QApplication::setOverrideCursor(Qt::WaitCursor);
  const std::string file = path.toStdString();
  watcher->setFuture(QtConcurrent::run([file, shot_file, options]() -> std::pair<ShotPtr, QString> {
    Result<hw::Shot> shot = shot_file ? app::readShot(file) : app::shotFromFootage(file, options);
    if (!shot) return {nullptr, QString::fromStdString(shot.error().message)};
    return {std::make_shared<const hw::Shot>(std::move(shot).value()), {}};
  }));
}

void MainWindow::storeResults(const QString& file, const std::string& id, std::string json) {
  if (file.isEmpty()) return;  // not saved (the save error was shown)
  const QFileInfo info(file);
  const std::string dir = info.absolutePath().toStdString();
  // Rewriting the file copies it (frames included): off the GUI thread, one at a time.
  auto* watcher = new QFutureWatcher<QString>(this);
  connect(watcher, &QFutureWatcher<QString>::finished, this, [this, watcher, id] {
    const QString error = watcher->result();
    watcher->deleteLater();
    if (!error.isEmpty()) showMessage(tr("Results of shot %1 not stored: %2").arg(qs(id), error));
    shot_browser_->refresh();
    campaign_view_->refresh();
    emit resultsStored(qs(id), error);
  });
  watcher->setFuture(
      QtConcurrent::run(&store_pool_, [dir, id, json = std::move(json)]() -> QString {
        Status s = app::saveResults(dir, id, json);
        return s ? QString() : QString::fromStdString(s.error().message);
      }));
}

void MainWindow::reanalyse(const QStringList& files) {
  delete progress_;
  progress_ = new QProgressDialog(tr("Re-running the analysis"), tr("Cancel"), 0,
                                  static_cast<int>(files.size()), this);
  progress_->setObjectName("progress");
  progress_->setWindowModality(Qt::NonModal);
  progress_->setMinimumDuration(0);
  batch_total_ = static_cast<int>(files.size());
  batch_done_ = 0;
  connect(progress_, &QProgressDialog::canceled, runner_, &AnalysisRunner::cancelQueued);
  for (const QString& f : files) runner_->analyzeFile(f, "batch");
  connect(runner_, &AnalysisRunner::pendingChanged, progress_, [this](int pending) {
    if (pending == 0 && progress_) {
      progress_->reset();
      shot_browser_->refresh();
    }
  });
}

bool MainWindow::beginCampaign(int shots, const QString& title) {
  if (const QString problem = shotsDirProblem(shots_dir_, false); !problem.isEmpty()) {
    showMessage(tr("Campaign not started: %1").arg(problem), MessageKind::Error,
                MessageTopic::ShotsDir);
    return false;
  }
  delete progress_;
  progress_ = new QProgressDialog(title, tr("Cancel"), 0, shots, this);
  progress_->setObjectName("progress");
  progress_->setWindowModality(Qt::NonModal);
  progress_->setMinimumDuration(0);
  progress_->setValue(0);
  connect(progress_, &QProgressDialog::canceled, this, [this] { worker_->requestCancel(); });
  campaign_view_->setCampaignRunning(true);
  campaign_running_ = true;
  return true;
}

app::CampaignOptions MainWindow::campaignOptions(int shots, quint64 seed, double angle_min,
                                                 double angle_max) const {
  app::CampaignOptions o;
  o.shots = shots;
  o.seed = seed;
  o.angle_min_deg = angle_min;
  o.angle_max_deg = angle_max;
  o.out_dir = shots_dir_.toStdString();
  return o;
}

void MainWindow::startCampaign(int shots, quint64 seed, double angle_min, double angle_max) {
  const app::CampaignOptions o = campaignOptions(shots, seed, angle_min, angle_max);
  if (beginCampaign(shots, tr("Firing the campaign"))) worker_->requestCampaign(o);
}

void MainWindow::startAdaptiveCampaign(int budget, quint64 seed, double angle_min, double angle_max,
                                       double target_sigma_mu, double target_sigma_beta0) {
  const app::CampaignOptions o = campaignOptions(budget, seed, angle_min, angle_max);
  AdaptiveOptions design;
  design.target_sigma_mu = target_sigma_mu;
  design.target_sigma_beta0 = target_sigma_beta0;
  // Bad targets or angle range: refused before the rig is touched.
  AdaptiveOptions checked = design;
  checked.angle_min_deg = angle_min, checked.angle_max_deg = angle_max;
  if (auto bad = chooseNextShot({}, {}, checked); !bad) {
    showMessage(tr("Adaptive campaign not started: %1").arg(qs(bad.error().message)));
    return;
  }
  if (beginCampaign(budget, tr("Firing the adaptive campaign (at most %1 shots)").arg(budget)))
    worker_->requestAdaptiveCampaign(o, design);
}

void MainWindow::onAdaptiveProgress(AdaptiveStepPtr step) {
  const app::AdaptiveShot& shot = step->shot;
  QString line = tr("Shot %1 (of at most %2) at %3%4: %5. Why: %6")
                     .arg(step->done)
                     .arg(step->budget)
                     .arg(shot.incidence_deg, 0, 'f', 1)
                     .arg(QString::fromUtf8("°"))
                     .arg(shot.id.empty() ? tr("not fired") : qs(shot.id))
                     .arg(qs(shot.why));
  if (!shot.note.empty()) line += tr(" Note: %1").arg(qs(shot.note));
  campaign_view_->addAdaptiveShot(line, step->sigmas);
  if (progress_) {
    progress_->setMaximum(step->budget);
    progress_->setValue(step->done);
    progress_->setLabelText(tr("Shot %1 of at most %2 fired and analysed.\n%3")
                                .arg(step->done)
                                .arg(step->budget)
                                .arg(step->sigmas));
  }
  // The engine analysed the shot and stored its results already: the views
  // only re-read the folder.
  shot_browser_->refresh();
  campaign_view_->refresh();
}

void MainWindow::openCalibrationDialog() {
  if (!profile_) {
    showMessage(tr("Open a rig profile first."));
    return;
  }
  auto* dialog = new CalibrationDialog(profile_, profile_path_, this);
  dialog->setAttribute(Qt::WA_DeleteOnClose);
  dialog->setLaunches(launches_);
  // The recorded shots of the folder, read on a worker.
  auto* watcher = new QFutureWatcher<std::vector<MeasuredLaunch>>(dialog);
  connect(watcher, &QFutureWatcher<std::vector<MeasuredLaunch>>::finished, dialog,
          [dialog, watcher] {
            std::vector<MeasuredLaunch> all = watcher->result();
            if (!all.empty()) dialog->setLaunches(std::move(all));
          });
  const std::string dir = shots_dir_.toStdString();
  std::vector<MeasuredLaunch> session = launches_;
  watcher->setFuture(QtConcurrent::run([dir, session]() {
    auto stored = measuredLaunchesInFolder(dir);
    if (!stored) return session;
    // Folder shots plus any session shot not (yet) stored there.
    std::vector<MeasuredLaunch> all = *stored;
    for (const auto& m : session) {
      bool known = false;
      for (const auto& s : all)
        known = known || (s.shot_id == m.shot_id && s.launcher == m.launcher);
      if (!known) all.push_back(m);
    }
    return all;
  }));
  connect(dialog, &CalibrationDialog::profileSaved, this,
          [this](QString path) { loadProfile(path); });
  dialog->show();
}

void MainWindow::restoreSettings() {
  QSettings s;
  restoreGeometry(s.value("window/geometry").toByteArray());
  restoreState(s.value("window/state").toByteArray());
  profile_path_ = s.value("rig/profile").toString();
  shots_dir_ = s.value("shots/dir").toString();
  tabs_->setCurrentIndex(s.value("window/tab", 0).toInt());
}

void MainWindow::saveSettings() {
  QSettings s;
  s.setValue("window/geometry", saveGeometry());
  s.setValue("window/state", saveState());
  s.setValue("window/tab", tabs_->currentIndex());
  s.setValue("rig/profile", profile_path_);
  s.setValue("shots/dir", shots_dir_);
}

void MainWindow::closeEvent(QCloseEvent* event) {
  if (campaign_running_ &&
      QMessageBox::question(this, tr("A campaign is running"),
                            tr("Stop the campaign and close? The shot being fired is finished "
                               "and saved first; shots not analysed yet can be analysed later "
                               "(Shots > Re-analyse)."),
                            QMessageBox::Yes | QMessageBox::Cancel,
                            QMessageBox::Cancel) != QMessageBox::Yes) {
    event->ignore();
    return;
  }
  if (options_.restore_settings) saveSettings();
  worker_->requestCancel();
  event->accept();
}

}  // namespace collide::gui
