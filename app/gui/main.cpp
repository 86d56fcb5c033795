// collide-gui: the lab GUI. `collide-gui --rig config/sim.toml` opens it on
// the simulated rig.
#include <QApplication>
#include <QCommandLineParser>

#include "app/gui/main_window.hpp"
#include "app/version.hpp"

int main(int argc, char** argv) {
  QApplication app(argc, argv);
  QApplication::setOrganizationName("collide");
  QApplication::setApplicationName("collide-gui");
  QApplication::setApplicationVersion(collide::kVersion);

  QCommandLineParser parser;
  parser.setApplicationDescription(
      "Collide lab GUI: fire shots on the rig, watch them live, replay and measure them.");
  parser.addHelpOption();
  parser.addVersionOption();
  QCommandLineOption rig("rig",
                         "Rig profile (TOML) to load; default: the last one used, else the "
                         "built-in simulated rig.",
                         "PROFILE");
  QCommandLineOption shots("shots",
                           "Folder where shots are saved (default: the last one used, "
                           "else ./shots).",
                           "DIR");
  parser.addOption(rig);
  parser.addOption(shots);
  parser.process(app);

  collide::gui::MainWindowOptions options;
  options.rig_profile = parser.value(rig);
  options.shots_dir = parser.value(shots);
  collide::gui::MainWindow window(options);
  window.show();
  return app.exec();
}
