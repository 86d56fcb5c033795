// collide-gui: the lab GUI. `collide-gui --rig config/sim.toml` opens it on
// the simulated rig.
#include <QApplication>
#include <QCommandLineParser>
#include <csignal>
#include <cstring>
#include <memory>

#include "app/gui/main_window.hpp"
#include "app/version.hpp"

int main(int argc, char** argv) {
  // A file size limit (ulimit -f) fails a save with a message, not the GUI.
  std::signal(SIGXFSZ, SIG_IGN);
  // --help and --version need no display: answer them without a GUI.
  bool text_only = false;
  for (int i = 1; i < argc; ++i)
    for (const char* flag : {"--help", "-h", "--help-all", "--version", "-v"})
      text_only = text_only || std::strcmp(argv[i], flag) == 0;
  std::unique_ptr<QCoreApplication> app(text_only ? new QCoreApplication(argc, argv)
                                                  : new QApplication(argc, argv));
  QCoreApplication::setOrganizationName("collide");
  QCoreApplication::setApplicationName("collide-gui");
  QCoreApplication::setApplicationVersion(collide::kVersion);

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
  parser.process(*app);  // exits after --help / --version

  collide::gui::MainWindowOptions options;
  options.rig_profile = parser.value(rig);
  options.shots_dir = parser.value(shots);
  collide::gui::MainWindow window(options);
  window.show();
  return app->exec();
}
