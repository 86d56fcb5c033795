#pragma once
// The shot browser: the catalog of a shot folder as a table, filtered by
// material, date and status. Opening a shot (double-click or Open) reads it
// on a worker thread and hands it on for replay; re-running the analysis of
// the selected or of all listed shots is asked for through signals.
#include <QFutureWatcher>
#include <QWidget>
#include <vector>

#include "app/gui/shot_analysis_service.hpp"
#include "app/store/catalog.hpp"

class QVBoxLayout;
class QComboBox;
class QDateEdit;
class QCheckBox;
class QLabel;
class QTableWidget;
class QPushButton;

namespace collide::gui {

class ShotBrowser : public QWidget {
  Q_OBJECT
 public:
  explicit ShotBrowser(QWidget* parent = nullptr);
  ~ShotBrowser() override;

  /// Lists the catalog of `dir` (nothing is created there if it has none).
  void setFolder(const QString& dir);
  QString folder() const { return dir_; }
  /// Re-reads the catalog, keeping the filters.
  void refresh();

  /// The filter as set in the widgets.
  app::ShotFilter filter() const;
  void setMaterialFilter(const QString& material);  ///< empty: any
  void setStatusFilter(const QString& status);      ///< "", "ok", "failed"
  const std::vector<app::CatalogRow>& rows() const { return rows_; }
  /// Opens listed row `index` (reads the file, then emits shotOpened).
  void openRow(int index);

 signals:
  void shotOpened(collide::gui::ShotPtr shot, QString file);
  void reanalyseRequested(QStringList files);
  void error(QString message);
  /// A note typed into the note column was stored in the shot's file and
  /// catalog row (error empty), or why not.
  void noteSaved(QString shot_id, QString error);

 private:
  // The constructor's parts, top to bottom.
  void addFolderRow(QVBoxLayout* layout);
  void addFilters(QVBoxLayout* layout);
  void addTable(QVBoxLayout* layout);
  void addButtons(QVBoxLayout* layout);
  void fill();
  QStringList selectedFiles() const;
  void saveNote(const std::string& id, const std::string& note);

  QString dir_;
  std::vector<app::CatalogRow> all_;   ///< every row of the catalog
  std::vector<app::CatalogRow> rows_;  ///< the listed ones
  QLabel* folder_label_ = nullptr;
  QComboBox* material_ = nullptr;
  QComboBox* status_ = nullptr;
  QCheckBox* use_dates_ = nullptr;
  QDateEdit* since_ = nullptr;
  QDateEdit* until_ = nullptr;
  QTableWidget* table_ = nullptr;
  QLabel* count_ = nullptr;
  struct ReadOutcome {
    ShotPtr shot;
    QString error;
  };
  QFutureWatcher<ReadOutcome> reader_;
  bool filling_ = false;
  QString reading_file_;
};

}  // namespace collide::gui
