// A real single-node Slurm cluster, started by this test as root in a
// scratch folder (its own munge key and socket, slurm.conf, ports, state and
// logs; SLURM_CONF points the client commands at it), analysing a 40-shot
// campaign as a 10-task job array with docs/examples/analyze-array.sbatch:
//   - the results stored in every shot equal a local `collide analyze`;
//   - a task SIGKILLed in the middle of its chunk and run again leaves every
//     shot readable, every result present, and no temporary file;
//   - the same manifest through `xargs -P 2` gives the same results.
// Skips, saying why, where the daemons cannot start (not root, Debian's
// slurm-wlm / munge missing, no loopback). The daemons die with the test
// (PR_SET_PDEATHSIG) and are stopped at the end, also after a failure.
#include <arpa/inet.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <thread>
#include <vector>

#include "app/report/results_summary.hpp"
#include "app/store/catalog.hpp"
#include "app/store/shot_file.hpp"

namespace {

namespace fs = std::filesystem;
using collide::app::ResultsSummary;
using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

const std::string kCollide = std::string(COLLIDE_BINARY_DIR) + "/app/collide";
const std::string kArrayScript =
    std::string(COLLIDE_SOURCE_DIR) + "/docs/examples/analyze-array.sbatch";
constexpr int kShots = 40, kChunk = 4;
/// A config/sim.toml shot file: 70 frames of 640 x 480 at 8 bits.
constexpr double kShotBytes = 21.6e6;
/// Disk the suite needs at its peak: the campaign, and one analysed copy
/// (storing results rewrites each hard-linked file as a new one), with a
/// margin. Each copy is removed once its test has passed, the local
/// reference once its results are read.
constexpr double kNeededBytes = 2.0 * kShots * kShotBytes * 1.25;

struct Shell {
  int exit_code = -1;
  std::string output;  // stdout and stderr
};

Shell sh(const std::string& command) {
  Shell run;
  FILE* pipe = popen(("(" + command + ") 2>&1").c_str(), "r");
  if (!pipe) return run;
  char buf[4096];
  std::size_t n;
  while ((n = fread(buf, 1, sizeof buf, pipe)) > 0) run.output.append(buf, n);
  const int status = pclose(pipe);
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return run;
}

std::string q(const std::string& s) {
  return "'" + s + "'";
}

std::string findProgram(const std::string& name) {
  for (const char* dir : {"/usr/sbin", "/usr/bin", "/sbin", "/bin", "/usr/local/bin"}) {
    const std::string p = std::string(dir) + "/" + name;
    if (access(p.c_str(), X_OK) == 0) return p;
  }
  return "";
}

std::string readAll(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string tail(const std::string& path, std::size_t chars = 1500) {
  const std::string text = readAll(path);
  return text.size() > chars ? text.substr(text.size() - chars) : text;
}

int freePort() {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof a;
  int port = 0;
  if (bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0 &&
      getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len) == 0)
    port = ntohs(a.sin_port);
  close(fd);
  return port;
}

/// munged, slurmctld and slurmd of a one-node cluster living in `dir`.
class SingleNodeSlurm {
 public:
  explicit SingleNodeSlurm(const std::string& dir) : dir_(dir) {
    if (geteuid() != 0) {
      why_not_ = "needs root to start slurmd and slurmctld (run as root, e.g. ./collide.sh test)";
      return;
    }
    for (const char* p : {"munged", "mungekey", "slurmctld", "slurmd", "sbatch", "squeue",
                          "scancel", "sinfo", "scontrol"})
      if (findProgram(p).empty()) {
        why_not_ = std::string(p) +
                   " is not installed (Debian packages slurm-wlm and munge; ./collide.sh installs "
                   "them)";
        return;
      }
    char host[256] = {};
    gethostname(host, sizeof host - 1);
    std::string node = host;
    node = node.substr(0, node.find('.'));
    // munged wants its socket's folder searchable by all.
    chmod(dir_.c_str(), 0755);
    fs::create_directories(dir_ + "/state");
    fs::create_directories(dir_ + "/spool");
    if (auto r = sh("mungekey -c -k " + q(dir_ + "/munge.key")); r.exit_code != 0) {
      why_not_ = "mungekey failed: " + r.output;
      return;
    }
    std::ofstream conf(conf_path());
    conf << "ClusterName=collidetest\n"
         << "SlurmctldHost=" << node << "(127.0.0.1)\n"
         << "SlurmUser=root\nSlurmdUser=root\n"
         << "SlurmctldPort=" << freePort() << "\nSlurmdPort=" << freePort() << "\n"
         << "AuthType=auth/munge\nCredType=cred/munge\n"
         << "AuthInfo=socket=" << dir_ << "/munge.sock\n"
         << "StateSaveLocation=" << dir_ << "/state\nSlurmdSpoolDir=" << dir_ << "/spool\n"
         << "SlurmctldPidFile=" << dir_ << "/slurmctld.pid\nSlurmdPidFile=" << dir_
         << "/slurmd.pid\n"
         << "SlurmctldLogFile=" << dir_ << "/slurmctld.log\nSlurmdLogFile=" << dir_
         << "/slurmd.log\n"
         << "ProctrackType=proctrack/linuxproc\nTaskPlugin=task/none\nSwitchType=switch/none\n"
         << "SelectType=select/cons_tres\nSelectTypeParameters=CR_Core\n"
         << "SchedulerType=sched/builtin\nJobCompType=jobcomp/none\n"
         << "AccountingStorageType=accounting_storage/none\n"
         << "JobAcctGatherType=jobacct_gather/none\nMpiDefault=none\nReturnToService=2\n"
         << "NodeName=" << node << " NodeAddr=127.0.0.1 CPUs=" << std::max(1u, cpus())
         << " RealMemory=" << memoryMB() << " State=UNKNOWN\n"
         << "PartitionName=test Nodes=" << node << " Default=YES MaxTime=INFINITE State=UP\n";
    conf.close();
    setenv("SLURM_CONF", conf_path().c_str(), 1);

    start("munged", {"munged", "-F", "--key-file=" + dir_ + "/munge.key",
                     "--socket=" + dir_ + "/munge.sock", "--pid-file=" + dir_ + "/munged.pid",
                     "--log-file=" + dir_ + "/munged.log", "--seed-file=" + dir_ + "/munge.seed"});
    if (!waitFor([&] { return fs::exists(dir_ + "/munge.sock"); }, 10s)) {
      why_not_ = "munged did not start: " + tail(dir_ + "/munged.out");
      return;
    }
    start("slurmctld", {"slurmctld", "-D", "-c", "-f", conf_path()});
    start("slurmd", {"slurmd", "-D", "-f", conf_path()});
    if (!waitFor([] { return sh("sinfo -h -o %t").output.find("idle") != std::string::npos; },
                 30s)) {
      why_not_ = "the node did not come up within 30 s (sinfo: " + sh("sinfo").output +
                 "); slurmctld: " + tail(dir_ + "/slurmctld.out", 600) +
                 tail(dir_ + "/slurmctld.log", 600) +
                 "; slurmd: " + tail(dir_ + "/slurmd.out", 600) + tail(dir_ + "/slurmd.log", 600);
    }
  }

  ~SingleNodeSlurm() {
    // Jobs first (their processes are not the daemons' children alone), then
    // the daemons in reverse order; SIGKILL whatever does not stop in 10 s.
    if (!daemons_.empty() && why_not_.empty()) {
      sh("scancel --full --signal=KILL --user=root; scancel --user=root");
      waitFor([] { return sh("squeue -h -t R,PD,CG").output.empty(); }, 15s);
    }
    for (auto it = daemons_.rbegin(); it != daemons_.rend(); ++it) kill(it->second, SIGTERM);
    for (auto it = daemons_.rbegin(); it != daemons_.rend(); ++it) {
      const auto until = Clock::now() + 10s;
      int status = 0;
      while (waitpid(it->second, &status, WNOHANG) == 0) {
        if (Clock::now() > until) {
          kill(it->second, SIGKILL);
          waitpid(it->second, &status, 0);
          break;
        }
        std::this_thread::sleep_for(50ms);
      }
    }
    unsetenv("SLURM_CONF");
  }

  /// Empty when the cluster is up; otherwise why it is not.
  const std::string& whyNot() const { return why_not_; }
  std::string conf_path() const { return dir_ + "/slurm.conf"; }
  const std::string& dir() const { return dir_; }

  template <class Pred>
  static bool waitFor(Pred pred, std::chrono::milliseconds limit) {
    const auto until = Clock::now() + limit;
    while (Clock::now() < until) {
      if (pred()) return true;
      std::this_thread::sleep_for(100ms);
    }
    return pred();
  }

 private:
  static unsigned cpus() { return std::thread::hardware_concurrency(); }
  /// The node's memory as slurmd measures it, less a margin (slurmd refuses a
  /// node configured with more than it has; the array script asks 1 GB a task).
  static long memoryMB() {
    const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGE_SIZE);
    return std::max(1000L, static_cast<long>(0.9 * pages / (1024.0 * 1024.0) * page));
  }

  void start(const std::string& name, const std::vector<std::string>& argv) {
    const std::string out = dir_ + "/" + name + ".out";
    const pid_t parent = getpid();
    const pid_t pid = fork();
    if (pid == 0) {
      // Dies with the test, even when the test itself is killed.
      prctl(PR_SET_PDEATHSIG, SIGKILL);
      if (getppid() != parent) _exit(127);
      FILE* f = freopen(out.c_str(), "w", stdout);
      (void)f;
      dup2(fileno(stdout), 2);
      std::vector<char*> args;
      for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
      args.push_back(nullptr);
      execvp(args[0], args.data());
      _exit(127);
    }
    if (pid > 0) daemons_.emplace_back(name, pid);
  }

  std::string dir_;
  std::string why_not_;
  std::vector<std::pair<std::string, pid_t>> daemons_;
};

/// Each shot file's results summary by file name ("" results: not analysed).
struct Stored {
  bool readable = false;
  bool has_results = false;
  ResultsSummary results;
  std::string error;
};
std::map<std::string, Stored> storedResults(const std::string& folder, bool frames = false) {
  std::map<std::string, Stored> out;
  for (const auto& e : fs::directory_iterator(folder)) {
    const std::string name = e.path().filename().string();
    if (e.path().extension() != ".h5" || name.front() == '.') continue;
    Stored s;
    auto shot = collide::app::readShot(e.path().string(), {.frames = frames, .contained = true});
    if (!shot) {
      s.error = shot.error().message;
    } else {
      s.readable = true;
      s.has_results = !shot->results_json.empty();
      if (s.has_results) {
        auto sum = collide::app::summarizeResults(shot->results_json);
        if (sum)
          s.results = *sum;
        else
          s.error = sum.error().message;
      }
    }
    out[name] = std::move(s);
  }
  return out;
}

void expectSameResults(const std::map<std::string, Stored>& expected,
                       const std::map<std::string, Stored>& actual, const std::string& what) {
  ASSERT_EQ(actual.size(), expected.size()) << what;
  int compared = 0;
  for (const auto& [name, exp] : expected) {
    auto it = actual.find(name);
    ASSERT_NE(it, actual.end()) << what << ": " << name << " missing";
    const Stored& act = it->second;
    EXPECT_TRUE(act.readable) << what << ": " << name << ": " << act.error;
    EXPECT_EQ(act.has_results, exp.has_results) << what << ": " << name;
    if (!act.has_results || !exp.has_results) continue;
    ++compared;
    EXPECT_EQ(act.results.e, exp.results.e) << what << ": " << name << " e";
    EXPECT_EQ(act.results.beta, exp.results.beta) << what << ": " << name << " beta";
    EXPECT_EQ(act.results.f, exp.results.f) << what << ": " << name << " f";
    EXPECT_EQ(act.results.gamma_deg, exp.results.gamma_deg) << what << ": " << name << " gamma";
    EXPECT_EQ(act.results.vn_m_s, exp.results.vn_m_s) << what << ": " << name << " vn";
    EXPECT_EQ(act.results.vs_m_s, exp.results.vs_m_s) << what << ": " << name << " vs";
    EXPECT_EQ(act.results.quality_flags, exp.results.quality_flags) << what << ": " << name;
  }
  EXPECT_GT(compared, kShots / 2) << what << ": too few analysed shots to compare";
}

/// The folder's catalog agrees with its files, and `collide catalog rebuild`
/// finds nothing to complain about (no unreadable file, no temporary file).
void expectCleanFolder(const std::string& folder) {
  std::vector<std::string> temps;
  for (const auto& e : fs::directory_iterator(folder))
    if (e.path().filename().string().find(".tmp-") != std::string::npos)
      temps.push_back(e.path().filename().string());
  EXPECT_TRUE(temps.empty()) << folder << ": temporary files left: " << temps.size();
  auto catalog = collide::app::Catalog::open(folder, collide::app::Catalog::Mode::OpenExisting);
  ASSERT_TRUE(catalog.ok()) << catalog.error().message;
  auto rows = catalog->query();
  ASSERT_TRUE(rows.ok());
  const auto files = storedResults(folder);
  for (const auto& row : *rows) {
    auto it = files.find(row.file);
    ASSERT_NE(it, files.end()) << row.file;
    EXPECT_EQ(row.analysed, it->second.has_results) << folder << ": catalog row of " << row.file;
    if (row.analysed && it->second.has_results) {
      EXPECT_EQ(row.results.e, it->second.results.e) << folder << ": catalog row of " << row.file;
    }
  }
  const Shell rebuild = sh(q(kCollide) + " catalog rebuild " + q(folder));
  EXPECT_EQ(rebuild.exit_code, 0) << rebuild.output;
  EXPECT_THAT(rebuild.output, ::testing::Not(::testing::HasSubstr("temporary file")));
  EXPECT_THAT(rebuild.output, ::testing::Not(::testing::HasSubstr("skipped")));
}

/// "... 10 analysed, ... 12.3 s, 0.812 shots/s" lines of the task outputs.
std::vector<double> shotsPerSecond(const std::string& text) {
  std::vector<double> out;
  static const std::regex rate(R"(([0-9.]+) shots/s)");
  for (std::sregex_iterator it(text.begin(), text.end(), rate), end; it != end; ++it)
    out.push_back(std::stod((*it)[1]));
  return out;
}

class SlurmCluster : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    std::string pattern = ::testing::TempDir() + "collide-slurm-XXXXXX";
    if (!mkdtemp(pattern.data())) return;
    root_ = new std::string(pattern);
    cluster_ = new SingleNodeSlurm(*root_);
    if (!cluster_->whyNot().empty()) return;
    std::error_code ec;
    const auto space = fs::space(*root_, ec);
    if (!ec && static_cast<double>(space.available) < kNeededBytes) {
      char why[400];
      std::snprintf(why, sizeof why,
                    "%.2f GB free in %s, the campaign and an analysed copy need %.2f GB: free "
                    "space there or point TEST_TMPDIR at a disk with room",
                    space.available / 1e9, root_->c_str(), kNeededBytes / 1e9);
      no_room_ = why;
      return;
    }
    const auto t0 = Clock::now();
    // The same seed fires the same shots: with seed 2 every shot of the 40
    // collides (with seed 1 one grazes past the other, which a job array
    // reports as a task that could not analyse every shot, exit status 1).
    const Shell campaign = sh(
        q(kCollide) + " campaign --rig " + q(std::string(COLLIDE_SOURCE_DIR) + "/config/sim.toml") +
        " --shots " + std::to_string(kShots) + " --out " + q(dir("shots")) + " --seed 2");
    campaign_error_ = campaign.exit_code == 0 ? "" : campaign.output;
    if (!campaign_error_.empty()) return;
    const auto t1 = Clock::now();
    // The reference: a plain local `collide analyze` of a copy.
    copyShots("local");
    const Shell local = sh(q(kCollide) + " analyze " + q(dir("local")));
    local_error_ = local.exit_code == 0 ? "" : local.output;
    const auto t2 = Clock::now();
    expected_ = new std::map<std::string, Stored>(storedResults(dir("local")));
    if (local_error_.empty()) removeCopy("local");
    std::printf("[ cluster  ] campaign of %d shots %.1f s; local analyze (all cores) %.1f s\n",
                kShots, std::chrono::duration<double>(t1 - t0).count(),
                std::chrono::duration<double>(t2 - t1).count());
  }

  static void TearDownTestSuite() {
    delete cluster_;  // stops the daemons
    cluster_ = nullptr;
    delete expected_;
    expected_ = nullptr;
    if (root_) {
      std::error_code ec;
      if (!::testing::UnitTest::GetInstance()->Passed()) {
        // The logs and outputs stay for a look; the shot files (about 0.9 GB
        // a copy, and the same seed fires them again) do not: a machine
        // that runs the suite often must not fill its disk with them.
        std::vector<fs::path> shots;
        for (auto it = fs::recursive_directory_iterator(*root_, ec);
             !ec && it != fs::recursive_directory_iterator(); it.increment(ec))
          if (it->is_regular_file() && it->path().extension() == ".h5") shots.push_back(it->path());
        for (const fs::path& f : shots) fs::remove(f, ec);
        std::printf(
            "[ cluster  ] kept %s for a look (slurm logs, task outputs; its %zu shot files "
            "removed: --seed 2 fires them again)\n",
            root_->c_str(), shots.size());
      } else {
        fs::remove_all(*root_, ec);
      }
      delete root_;
      root_ = nullptr;
    }
  }

  void SetUp() override {
    if (!root_) GTEST_SKIP() << "cannot make a scratch folder";
    if (!cluster_->whyNot().empty())
      GTEST_SKIP() << "no single-node Slurm cluster: " << cluster_->whyNot();
    if (!no_room_.empty()) GTEST_SKIP() << "no room for the campaign: " << no_room_;
    ASSERT_TRUE(campaign_error_.empty()) << "collide campaign failed: " << campaign_error_;
    ASSERT_TRUE(local_error_.empty()) << "local collide analyze failed: " << local_error_;
  }

  /// A passing test's copy goes (its shot files are 0.9 GB); a failing
  /// one's stays for a look until the suite's end (TearDownTestSuite).
  void TearDown() override {
    if (!copy_.empty() && !HasFailure()) removeCopy(copy_);
  }

  static void removeCopy(const std::string& name) {
    std::error_code ec;
    fs::remove_all(dir(name), ec);
  }

  static std::string dir(const std::string& name) { return *root_ + "/" + name; }

  /// A copy of the campaign folder: the shot files hard-linked (0.9 GB copied
  /// four times would take most of the test's time), the catalog copied.
  /// Sound because a shot file is never changed in place: storing results
  /// writes a new file and renames it over the name (app/store/shot_file.hpp),
  /// which the other copies' links do not see.
  static void copyShots(const std::string& name) {
    const Shell cp =
        sh("mkdir " + q(dir(name)) + " && ln " + q(dir("shots")) + "/*.h5 " + q(dir(name)) +
           "/ && cp " + q(dir("shots")) + "/catalog.sqlite* " + q(dir(name)) + "/");
    EXPECT_EQ(cp.exit_code, 0) << cp.output;
  }

  /// Copies the campaign to `name` and writes its manifest; the manifest's path.
  std::string prepare(const std::string& name) {
    copy_ = name;
    copyShots(name);
    const std::string list = dir(name + ".list");
    const Shell m = sh(q(kCollide) + " manifest " + q(dir(name)) + " --out " + q(list) +
                       " --chunk " + std::to_string(kChunk));
    EXPECT_EQ(m.exit_code, 0) << m.output;
    EXPECT_THAT(m.output, ::testing::HasSubstr("--array=0-9"));
    return list;
  }

  std::string copy_;  // this test's copy of the campaign

  static std::string sbatch(const std::string& args) {
    return "cd " + q(*root_) + " && COLLIDE=" + q(kCollide) + " sbatch " + args;
  }

  static inline std::string* root_ = nullptr;
  static inline SingleNodeSlurm* cluster_ = nullptr;
  static inline std::map<std::string, Stored>* expected_ = nullptr;
  static inline std::string campaign_error_, local_error_, no_room_;
};

TEST_F(SlurmCluster, AJobArrayOfTenTasksStoresTheSameResultsAsALocalAnalyze) {
  const std::string list = prepare("array");
  const auto t0 = Clock::now();
  const Shell job = sh(sbatch("--wait --array=0-9 --output=" + q(dir("array-%a.out")) + " " +
                              q(kArrayScript) + " " + q(list) + " " + std::to_string(kChunk)));
  const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  std::string outputs;
  for (int i = 0; i < 10; ++i) outputs += readAll(dir("array-" + std::to_string(i) + ".out"));
  ASSERT_EQ(job.exit_code, 0) << job.output << "\n" << outputs;
  for (int i = 0; i < 10; ++i)
    EXPECT_THAT(outputs, ::testing::HasSubstr("task " + std::to_string(i) + " (shots " +
                                              std::to_string(i * kChunk) + "-"));
  const auto rates = shotsPerSecond(outputs);
  EXPECT_EQ(rates.size(), 10u);
  double sum = 0;
  for (double r : rates) sum += r;
  std::printf(
      "[ cluster  ] 10-task array (1 CPU a task): %.1f s from sbatch to done, %.3f "
      "shots/s per task (mean)\n",
      seconds, rates.empty() ? 0.0 : sum / rates.size());
  expectSameResults(*expected_, storedResults(dir("array")), "job array");
  expectCleanFolder(dir("array"));

  // The reduce step: fit the campaign from the manifest.
  const Shell fit =
      sh(q(kCollide) + " fit --manifest " + q(list) + " --out " + q(dir("fit")) + " --bootstrap 0");
  EXPECT_EQ(fit.exit_code, 0) << fit.output;
  EXPECT_TRUE(fs::exists(dir("fit/fit.json"))) << fit.output;
}

TEST_F(SlurmCluster, ATaskKilledMidwayAndRunAgainLeavesNothingHalfDone) {
  const std::string list = prepare("killed");
  std::vector<std::string> chunk;  // task 0's shots
  {
    std::ifstream in(list);
    for (std::string line; chunk.size() < kChunk && std::getline(in, line);) chunk.push_back(line);
  }
  std::map<std::string, ino_t> inode;
  auto inodeOf = [](const std::string& p) {
    struct stat st {};
    return stat(p.c_str(), &st) == 0 ? st.st_ino : ino_t{0};
  };
  for (const auto& p : chunk) inode[p] = inodeOf(p);
  auto storedSoFar = [&] {
    int n = 0;
    for (const auto& p : chunk) n += inodeOf(p) != inode[p];  // replaced by a store
    return n;
  };
  auto tempsNow = [&] {
    int n = 0;
    for (const auto& e : fs::directory_iterator(dir("killed")))
      n += e.path().filename().string().find(".tmp-") != std::string::npos;
    return n;
  };

  const Shell submit =
      sh(sbatch("--parsable --array=0 --output=" + q(dir("killed-first.out")) + " " +
                q(kArrayScript) + " " + q(list) + " " + std::to_string(kChunk)));
  ASSERT_EQ(submit.exit_code, 0) << submit.output;
  const std::string job = submit.output.substr(0, submit.output.find_first_of(";\n"));
  // Once a shot is stored, kill the task the moment a store is in flight
  // (its temporary copy exists): a SIGKILL in the middle of a write.
  ASSERT_TRUE(SingleNodeSlurm::waitFor([&] { return storedSoFar() >= 1; }, 120s))
      << "task 0 stored nothing: " << readAll(dir("killed-first.out"));
  const auto until = Clock::now() + 20s;
  while (tempsNow() == 0 && Clock::now() < until) std::this_thread::sleep_for(1ms);
  // The task's collide processes: this test started them, through Slurm.
  std::vector<pid_t> killed;
  for (const auto& e : fs::directory_iterator("/proc")) {
    const std::string name = e.path().filename().string();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    if (readAll(e.path().string() + "/comm").rfind("collide", 0) != 0) continue;
    const std::string env = readAll(e.path().string() + "/environ");
    if (env.find(std::string("SLURM_ARRAY_JOB_ID=") + job + '\0') != std::string::npos ||
        env.find(std::string("SLURM_JOB_ID=") + job + '\0') != std::string::npos)
      killed.push_back(static_cast<pid_t>(std::stol(name)));
  }
  for (pid_t pid : killed) kill(pid, SIGKILL);
  const int stored_at_kill = storedSoFar();
  const int temps_at_kill = tempsNow();
  ASSERT_FALSE(killed.empty()) << "no collide process of job " << job << " to kill";
  ASSERT_TRUE(
      SingleNodeSlurm::waitFor([&] { return sh("squeue -h -j " + job).output.empty(); }, 30s));
  std::printf("[ cluster  ] killed task 0 with %d of %d shots stored, %d temporary file(s)\n",
              stored_at_kill, kChunk, temps_at_kill);
  EXPECT_LT(stored_at_kill, kChunk) << "the task finished before it was killed";
  // Every shot file is still a complete shot.
  for (const auto& [name, s] : storedResults(dir("killed"), /*frames=*/true))
    EXPECT_TRUE(s.readable) << name << ": " << s.error;

  // Run again: the task completes, the killed store's copy is gone.
  const Shell again = sh(sbatch("--wait --array=0 --output=" + q(dir("killed-again.out")) + " " +
                                q(kArrayScript) + " " + q(list) + " " + std::to_string(kChunk)));
  ASSERT_EQ(again.exit_code, 0) << again.output << readAll(dir("killed-again.out"));
  const auto after = storedResults(dir("killed"));
  for (const auto& p : chunk) {
    const auto it = after.find(fs::path(p).filename().string());
    ASSERT_NE(it, after.end()) << p;
    EXPECT_EQ(it->second.has_results, expected_->at(it->first).has_results) << p;
    EXPECT_EQ(it->second.results.e, expected_->at(it->first).results.e) << p;
    EXPECT_EQ(it->second.results.beta, expected_->at(it->first).results.beta) << p;
  }
  expectCleanFolder(dir("killed"));
}

TEST_F(SlurmCluster, TheSameManifestThroughXargsStoresTheSameResults) {
  const std::string list = prepare("xargs");
  const auto t0 = Clock::now();
  const Shell run = sh("seq 0 9 | xargs -P 2 -I{} " + q(kCollide) + " analyze --manifest " +
                       q(list) + " --chunk " + std::to_string(kChunk) + " --index {} --jobs 1");
  const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const auto rates = shotsPerSecond(run.output);
  double sum = 0;
  for (double r : rates) sum += r;
  std::printf(
      "[ cluster  ] xargs -P 2, 10 tasks: %.1f s, %.2f shots/s overall, %.3f shots/s "
      "per task (mean)\n",
      seconds, kShots / seconds, rates.empty() ? 0.0 : sum / rates.size());
  EXPECT_EQ(rates.size(), 10u);
  expectSameResults(*expected_, storedResults(dir("xargs")), "xargs -P 2");
  expectCleanFolder(dir("xargs"));

  // Errors a task reports: an index past the end, a shot that is gone.
  const Shell past = sh(q(kCollide) + " analyze --manifest " + q(list) + " --chunk " +
                        std::to_string(kChunk) + " --index 10");
  EXPECT_EQ(past.exit_code, 2);
  EXPECT_THAT(past.output, ::testing::HasSubstr("--array=0-9"));
  std::string first;
  {
    std::ifstream in(list);
    std::getline(in, first);
  }
  fs::rename(first, first + ".moved");
  const Shell gone = sh(q(kCollide) + " analyze --manifest " + q(list) + " --chunk 2 --index 0");
  EXPECT_EQ(gone.exit_code, 1) << gone.output;
  EXPECT_THAT(gone.output, ::testing::HasSubstr(list + ":1: "));
  EXPECT_THAT(gone.output, ::testing::HasSubstr(first));
}

}  // namespace
