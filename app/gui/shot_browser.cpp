#include "app/gui/shot_browser.hpp"

#include <QCheckBox>
#include <QComboBox>
#include <QDateEdit>
#include <QDateTime>
#include <QDir>
#include <QFileDialog>
#include <QHBoxLayout>
#include <QHeaderView>
#include <QLabel>
#include <QPushButton>
#include <QTableWidget>
#include <QVBoxLayout>
#include <QtConcurrent/QtConcurrentRun>
#include <cmath>
#include <set>

#include "app/store/save.hpp"
#include "app/store/shot_file.hpp"

namespace collide::gui {
namespace {

QString qs(const std::string& s) {
  return QString::fromStdString(s);
}

QString number(const std::optional<double>& v, int decimals) {
  return v && std::isfinite(*v) ? QString::number(*v, 'f', decimals) : QString();
}

enum Column {
  kId,
  kTime,
  kMaterial,
  kStatus,
  kFrames,
  kSpeeds,
  kE,
  kBeta,
  kF,
  kGamma,
  kVn,
  kVs,
  kFlags,
  kNote,
  kColumns
};

}  // namespace

ShotBrowser::ShotBrowser(QWidget* parent) : QWidget(parent) {
  auto* layout = new QVBoxLayout(this);
  addFolderRow(layout);
  addFilters(layout);
  addTable(layout);
  addButtons(layout);
  connect(&reader_, &QFutureWatcher<ReadOutcome>::finished, this, [this] {
    const ReadOutcome r = reader_.result();
    if (!r.shot) {
      emit error(tr("Cannot open the shot: %1").arg(r.error));
      return;
    }
    emit shotOpened(r.shot, reading_file_);
  });
}

// The folder shown, and the buttons to choose another or read it again.
void ShotBrowser::addFolderRow(QVBoxLayout* layout) {
  auto* top = new QHBoxLayout;
  folder_label_ = new QLabel(tr("no folder"));
  folder_label_->setObjectName("folder_label");
  auto* choose = new QPushButton(tr("Folder..."));
  auto* refresh_button = new QPushButton(tr("Refresh"));
  refresh_button->setObjectName("refresh_shots");
  top->addWidget(folder_label_, 1);
  top->addWidget(choose);
  top->addWidget(refresh_button);
  layout->addLayout(top);

  connect(choose, &QPushButton::clicked, this, [this] {
    const QString dir = QFileDialog::getExistingDirectory(this, tr("Shot folder"), dir_);
    if (!dir.isEmpty()) setFolder(dir);
  });
  connect(refresh_button, &QPushButton::clicked, this, &ShotBrowser::refresh);
}

// Material, status and dates: the table shows the shots that match.
void ShotBrowser::addFilters(QVBoxLayout* layout) {
  auto* filters = new QHBoxLayout;
  material_ = new QComboBox;
  material_->setObjectName("material_filter");
  material_->addItem(tr("any material"), QString());
  status_ = new QComboBox;
  status_->setObjectName("status_filter");
  status_->addItem(tr("any status"), QString());
  status_->addItem(tr("ok"), QString("ok"));
  status_->addItem(tr("failed"), QString("failed"));
  use_dates_ = new QCheckBox(tr("dates"));
  use_dates_->setObjectName("date_filter");
  since_ = new QDateEdit(QDate::currentDate().addDays(-7));
  since_->setObjectName("since_date");
  until_ = new QDateEdit(QDate::currentDate());
  until_->setObjectName("until_date");
  for (auto* d : {since_, until_}) {
    d->setCalendarPopup(true);
    d->setDisplayFormat("yyyy-MM-dd");
  }
  filters->addWidget(material_);
  filters->addWidget(status_);
  filters->addWidget(use_dates_);
  filters->addWidget(new QLabel(tr("from")));
  filters->addWidget(since_);
  filters->addWidget(new QLabel(tr("to")));
  filters->addWidget(until_);
  filters->addStretch();
  layout->addLayout(filters);

  for (auto* c : {material_, status_})
    connect(c, &QComboBox::currentIndexChanged, this, &ShotBrowser::fill);
  connect(use_dates_, &QCheckBox::toggled, this, &ShotBrowser::fill);
  connect(since_, &QDateEdit::dateChanged, this, &ShotBrowser::fill);
  connect(until_, &QDateEdit::dateChanged, this, &ShotBrowser::fill);
}

// One row a shot; a double click opens it, its note is edited in place.
void ShotBrowser::addTable(QVBoxLayout* layout) {
  table_ = new QTableWidget(0, kColumns);
  table_->setObjectName("shot_table");
  table_->setHorizontalHeaderLabels({tr("shot"), tr("time (local)"), tr("material"), tr("status"),
                                     tr("frames"), tr("speeds (m/s)"), "e", "beta", "f",
                                     tr("gamma (deg)"), "v_n (m/s)", "v_s (m/s)",
                                     tr("flags / reason"), tr("note")});
  table_->horizontalHeaderItem(kNote)->setToolTip(
      tr("Your note on the shot, kept in its file: select the cell and press F2 (or click it "
         "again) to write it, Enter to store it"));
  table_->setSelectionBehavior(QAbstractItemView::SelectRows);
  // Only the note column is editable (its items say so), by F2 or a click on
  // the selected cell: a double click still opens the shot.
  table_->setEditTriggers(QAbstractItemView::EditKeyPressed | QAbstractItemView::SelectedClicked);
  table_->horizontalHeader()->setStretchLastSection(true);
  table_->verticalHeader()->hide();
  layout->addWidget(table_, 1);

  connect(table_, &QTableWidget::cellDoubleClicked, this, [this](int row, int) { openRow(row); });
  connect(table_, &QTableWidget::itemChanged, this, [this](QTableWidgetItem* item) {
    if (filling_ || item->column() != kNote || item->row() >= static_cast<int>(rows_.size()))
      return;
    const app::CatalogRow& r = rows_[item->row()];
    const std::string note = item->text().trimmed().toStdString();
    if (note != r.note) saveNote(r.id, note);
  });
}

void ShotBrowser::addButtons(QVBoxLayout* layout) {
  auto* bottom = new QHBoxLayout;
  count_ = new QLabel;
  count_->setObjectName("shot_count");
  auto* open = new QPushButton(tr("Open"));
  open->setObjectName("open_shot");
  auto* reanalyse = new QPushButton(tr("Re-run analysis of selected"));
  reanalyse->setObjectName("reanalyse_selected");
  auto* reanalyse_all = new QPushButton(tr("Re-run analysis of all listed"));
  reanalyse_all->setObjectName("reanalyse_all");
  bottom->addWidget(count_, 1);
  bottom->addWidget(open);
  bottom->addWidget(reanalyse);
  bottom->addWidget(reanalyse_all);
  layout->addLayout(bottom);

  connect(open, &QPushButton::clicked, this, [this] {
    if (table_->currentRow() >= 0) openRow(table_->currentRow());
  });
  connect(reanalyse, &QPushButton::clicked, this, [this] {
    if (QStringList f = selectedFiles(); !f.isEmpty()) emit reanalyseRequested(f);
  });
  connect(reanalyse_all, &QPushButton::clicked, this, [this] {
    QStringList files;
    for (const auto& r : rows_) files << QDir(dir_).filePath(qs(r.file));
    if (!files.isEmpty()) emit reanalyseRequested(files);
  });
}

ShotBrowser::~ShotBrowser() {
  reader_.waitForFinished();
}

void ShotBrowser::setFolder(const QString& dir) {
  dir_ = dir;
  folder_label_->setText(dir);
  refresh();
}

void ShotBrowser::refresh() {
  all_.clear();
  if (dir_.isEmpty()) return fill();
  auto catalog = app::Catalog::open(dir_.toStdString(), app::Catalog::Mode::OpenExisting);
  if (catalog) {
    auto rows = catalog->query();
    if (rows)
      all_ = std::move(rows).value();
    else
      emit error(qs(rows.error().message));
  } else if (QDir(dir_).exists() && !QDir(dir_).entryList({"*.h5"}).isEmpty()) {
    emit error(tr("%1: run `collide catalog rebuild %2` to list its shots")
                   .arg(qs(catalog.error().message), dir_));
  }
  // Materials seen in this folder, keeping the current choice.
  const QString current = material_->currentData().toString();
  std::set<std::string> materials;
  for (const auto& r : all_) materials.insert(r.material);
  material_->blockSignals(true);
  material_->clear();
  material_->addItem(tr("any material"), QString());
  for (const auto& m : materials) material_->addItem(qs(m), qs(m));
  material_->setCurrentIndex(std::max(0, material_->findData(current)));
  material_->blockSignals(false);
  fill();
}

app::ShotFilter ShotBrowser::filter() const {
  app::ShotFilter f;
  if (const QString m = material_->currentData().toString(); !m.isEmpty())
    f.material = m.toStdString();
  if (const QString s = status_->currentData().toString(); !s.isEmpty())
    f.status = app::parseShotStatus(s.toStdString());
  if (use_dates_->isChecked()) {
    f.since_unix_ns = QDateTime(since_->date(), QTime(0, 0)).toMSecsSinceEpoch() * 1'000'000LL;
    f.until_unix_ns =
        QDateTime(until_->date().addDays(1), QTime(0, 0)).toMSecsSinceEpoch() * 1'000'000LL;
  }
  return f;
}

void ShotBrowser::setMaterialFilter(const QString& material) {
  material_->setCurrentIndex(std::max(0, material_->findData(material)));
}

void ShotBrowser::setStatusFilter(const QString& status) {
  status_->setCurrentIndex(std::max(0, status_->findData(status)));
}

void ShotBrowser::fill() {
  // The same conditions as Catalog::query's filter, applied to the rows read.
  const app::ShotFilter f = filter();
  rows_.clear();
  for (const auto& r : all_) {
    if (f.material && r.material != *f.material) continue;
    if (f.status && r.status != *f.status) continue;
    if (f.since_unix_ns && r.wall_time_unix_ns < *f.since_unix_ns) continue;
    if (f.until_unix_ns && r.wall_time_unix_ns >= *f.until_unix_ns) continue;
    rows_.push_back(r);
  }
  filling_ = true;  // the items set below are not the user's edits
  table_->setRowCount(static_cast<int>(rows_.size()));
  for (int i = 0; i < static_cast<int>(rows_.size()); ++i) {
    const app::CatalogRow& r = rows_[i];
    const auto& res = r.results;
    QString speeds;
    if (std::isfinite(r.wanted_speed_m_s[0]))
      speeds = QString("%1, %2")
                   .arg(r.wanted_speed_m_s[0], 0, 'f', 2)
                   .arg(r.wanted_speed_m_s[1], 0, 'f', 2);
    const QString cells[kColumns] = {
        qs(r.id),
        QDateTime::fromMSecsSinceEpoch(r.wall_time_unix_ns / 1'000'000)
            .toString("yyyy-MM-dd hh:mm:ss"),
        qs(r.material),
        hw::toString(r.status),
        QString::number(r.frames),
        speeds,
        number(res.e, 4),
        number(res.beta, 3),
        number(res.f, 3),
        number(res.gamma_deg, 1),
        number(res.vn_m_s, 3),
        number(res.vs_m_s, 3),
        r.status == hw::ShotStatus::Failed ? qs(r.failure_reason)
                                           : qs(app::joinFlags(res.quality_flags)),
        qs(r.note),
    };
    for (int c = 0; c < kColumns; ++c) {
      auto* item = new QTableWidgetItem(cells[c]);
      if (c != kNote) item->setFlags(item->flags() & ~Qt::ItemIsEditable);
      if (c == kStatus && r.status == hw::ShotStatus::Failed)
        item->setForeground(QColor(170, 40, 30));
      table_->setItem(i, c, item);
    }
  }
  filling_ = false;
  table_->resizeColumnsToContents();
  count_->setText(tr("%1 of %2 shots listed").arg(rows_.size()).arg(all_.size()));
}

void ShotBrowser::saveNote(const std::string& id, const std::string& note) {
  // Rewriting the file copies it (frames included): off the GUI thread.
  auto* watcher = new QFutureWatcher<QString>(this);
  connect(watcher, &QFutureWatcher<QString>::finished, this, [this, watcher, id] {
    const QString problem = watcher->result();
    watcher->deleteLater();
    if (!problem.isEmpty())
      emit error(tr("The note on shot %1 was not stored: %2").arg(qs(id), problem));
    refresh();
    emit noteSaved(qs(id), problem);
  });
  watcher->setFuture(QtConcurrent::run([dir = dir_.toStdString(), id, note]() -> QString {
    Status s = app::saveNote(dir, id, note);
    return s ? QString() : QString::fromStdString(s.error().message);
  }));
}

QStringList ShotBrowser::selectedFiles() const {
  QStringList files;
  std::set<int> seen;
  for (const auto& index : table_->selectionModel()->selectedRows())
    if (seen.insert(index.row()).second && index.row() < static_cast<int>(rows_.size()))
      files << QDir(dir_).filePath(qs(rows_[index.row()].file));
  return files;
}

void ShotBrowser::openRow(int index) {
  if (index < 0 || index >= static_cast<int>(rows_.size()) || reader_.isRunning()) return;
  reading_file_ = QDir(dir_).filePath(qs(rows_[index].file));
  const std::string path = reading_file_.toStdString();
  reader_.setFuture(QtConcurrent::run([path]() -> ReadOutcome {
    Result<hw::Shot> shot = app::readShot(path);
    if (!shot) return {nullptr, QString::fromStdString(shot.error().message)};
    return {std::make_shared<const hw::Shot>(std::move(shot).value()), {}};
  }));
}

}  // namespace collide::gui
