// `collide sim-regulator` as a program: started by the test, checked with an
// independent Modbus client (Debian's mbpoll) and with our own Modbus
// backend, over loopback TCP and over a socat pty pair (RTU). Skips with a
// message when mbpoll or socat is missing.
#include <fcntl.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <regex>
#include <string>
#include <thread>
#include <vector>

#include "../hw/modbus_peer.hpp"
#include "hw/modbus_map.hpp"
#include "hw/pressure_regulator_modbus.hpp"
#include "hw/rig_profile.hpp"

using namespace collide::hw;
using namespace collide::hw::testing;
using ::testing::HasSubstr;

namespace {

const std::string kCollide = std::string(COLLIDE_BINARY_DIR) + "/app/collide";

std::string configPath(const std::string& name) {
  return std::string(COLLIDE_SOURCE_DIR) + "/config/" + name;
}

struct ShellRun {
  int status = -1;
  std::string output;
};

// Runs a shell command, stdout and stderr together.
ShellRun shell(const std::string& command) {
  ShellRun r;
  FILE* p = ::popen((command + " 2>&1").c_str(), "r");
  if (!p) return r;
  char buf[4096];
  for (std::size_t n; (n = std::fread(buf, 1, sizeof buf, p)) > 0;) r.output.append(buf, n);
  const int w = ::pclose(p);
  r.status = WIFEXITED(w) ? WEXITSTATUS(w) : -1;
  return r;
}

// `collide sim-regulator ARGS` running in the background, its output collected.
class SimRegulatorProcess {
 public:
  explicit SimRegulatorProcess(const std::vector<std::string>& args) {
    int out[2];
    if (::pipe(out) != 0) return;
    pid_ = ::fork();
    if (pid_ == 0) {
      ::dup2(out[1], STDOUT_FILENO);
      ::dup2(out[1], STDERR_FILENO);
      ::close(out[0]);
      std::vector<char*> argv{const_cast<char*>(kCollide.c_str()),
                              const_cast<char*>("sim-regulator")};
      for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
      argv.push_back(nullptr);
      ::execv(kCollide.c_str(), argv.data());
      ::_exit(127);
    }
    ::close(out[1]);
    fd_ = out[0];
  }
  ~SimRegulatorProcess() {
    if (pid_ > 0 && !exited_) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
    if (fd_ >= 0) ::close(fd_);
  }

  // Reads output until it contains `text` or `timeout_s` passes.
  bool waitFor(const std::string& text, double timeout_s = 10.0) {
    const auto deadline = std::chrono::steady_clock::now() +
                          std::chrono::milliseconds(static_cast<int>(timeout_s * 1000));
    while (output_.find(text) == std::string::npos) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
                            deadline - std::chrono::steady_clock::now())
                            .count();
      if (left <= 0) return false;
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, static_cast<int>(left)) <= 0) return false;
      char buf[1024];
      const ssize_t n = ::read(fd_, buf, sizeof buf);
      if (n <= 0) return output_.find(text) != std::string::npos;
      output_.append(buf, static_cast<std::size_t>(n));
    }
    return true;
  }
  // Sends `sig` and waits for the exit status (-1 if killed by a signal).
  int stop(int sig = SIGINT) {
    ::kill(pid_, sig);
    waitFor("\x01", 5.0);  // drain to end of output
    int w = 0;
    ::waitpid(pid_, &w, 0);
    exited_ = true;
    return WIFEXITED(w) ? WEXITSTATUS(w) : -1;
  }
  // Waits for the program to end by itself; its exit status.
  int wait() {
    waitFor("\x01", 10.0);
    int w = 0;
    ::waitpid(pid_, &w, 0);
    exited_ = true;
    return WIFEXITED(w) ? WEXITSTATUS(w) : -1;
  }
  const std::string& output() const { return output_; }
  // The TCP port from "serving ... on 127.0.0.1:PORT".
  int port() const {
    std::smatch m;
    static const std::regex re("on 127\\.0\\.0\\.1:([0-9]+)");
    return std::regex_search(output_, m, re) ? std::stoi(m[1]) : -1;
  }

 private:
  pid_t pid_ = -1;
  int fd_ = -1;
  bool exited_ = false;
  std::string output_;
};

// The values mbpoll printed as "[ref]: value" lines.
std::vector<std::string> mbpollValues(const std::string& output) {
  std::vector<std::string> values;
  static const std::regex re("\\[[0-9]+\\]:\\s+(\\S+)");
  for (auto it = std::sregex_iterator(output.begin(), output.end(), re);
       it != std::sregex_iterator(); ++it)
    values.push_back((*it)[1]);
  return values;
}

class SimRegulatorPeer : public ::testing::Test {
 protected:
  void SetUp() override {
    if (findProgram("mbpoll").empty())
      GTEST_SKIP() << "mbpoll is not installed (Debian package mbpoll): it is the independent "
                      "Modbus client these tests check the server with";
  }

  // Our backend, pointed at `link`, open and running.
  std::unique_ptr<PressureRegulatorModbus> client(ModbusRegulatorMap map) {
    auto reg = std::make_unique<PressureRegulatorModbus>(map, 200.0, map.link.endpoint());
    EXPECT_TRUE(reg->open());
    EXPECT_TRUE(reg->configure({0.0, 200.0}));
    EXPECT_TRUE(reg->start());
    return reg;
  }
};

}  // namespace

TEST_F(SimRegulatorPeer, MbpollAndOurBackendAgreeOverTcp) {
  SimRegulatorProcess server({"--tcp", "127.0.0.1:0"});
  ASSERT_TRUE(server.waitFor("Ctrl-C stops.")) << server.output();
  EXPECT_THAT(server.output(), HasSubstr("setpoints: holding registers 0, 1 (u16, x0.001 bar)"));
  const std::string mb = "mbpoll -m tcp -a 1 -1 -o 1 -p " + std::to_string(server.port()) + " ";
  // mbpoll writes 5 bar (5000 mbar counts) into holding register 1 (1-based: address 0).
  const ShellRun write = shell(mb + "-t 4 -r 1 127.0.0.1 5000");
  ASSERT_EQ(write.status, 0) << write.output;
  EXPECT_THAT(write.output, HasSubstr("Written 1 references"));
  // The measured pressure (input register 1) follows; mbpoll sees it arrive.
  std::vector<std::string> values;
  for (int i = 0; i < 50; ++i) {
    const ShellRun read = shell(mb + "-t 3 -r 1 -c 2 127.0.0.1");
    ASSERT_EQ(read.status, 0) << read.output;
    values = mbpollValues(read.output);
    ASSERT_EQ(values.size(), 2u) << read.output;
    if (std::abs(std::stoi(values[0]) - 5000) <= 2) break;
  }
  EXPECT_NEAR(std::stoi(values[0]), 5000, 2);
  EXPECT_EQ(values[1], "0");
  // Our backend reads the same device: 500 kPa on channel 0.
  ModbusRegulatorMap map = ModbusRegulatorMap::generic10Bar();
  map.link.port = server.port();
  auto reg = client(map);
  EXPECT_NEAR(*reg->readPressureKPa(0), 500.0, 0.3);
  // ... and what it writes, mbpoll reads: 123.4 kPa is 1234 mbar counts.
  ASSERT_TRUE(reg->setPressureKPa(1, 123.4));
  const ShellRun setpoints = shell(mb + "-t 4 -r 1 -c 2 127.0.0.1");
  EXPECT_EQ(mbpollValues(setpoints.output), (std::vector<std::string>{"5000", "1234"}))
      << setpoints.output;
  reg.reset();
  EXPECT_EQ(server.stop(), 0);
  EXPECT_THAT(server.output(), HasSubstr("collide sim-regulator: stopped after"));
}

TEST_F(SimRegulatorPeer, MbpollAndOurBackendAgreeOverRtu) {
  if (const std::string why = SocatPtyPair::missing(); !why.empty()) GTEST_SKIP() << why;
  SocatPtyPair pty;
  ASSERT_TRUE(pty.error().empty()) << pty.error();
  SimRegulatorProcess server({"--rtu", pty.a()});
  ASSERT_TRUE(server.waitFor("Ctrl-C stops.")) << server.output();
  EXPECT_THAT(server.output(), HasSubstr("Modbus RTU on " + pty.a() + ", unit 1"));
  const std::string mb = "mbpoll -m rtu -b 19200 -P none -a 1 -1 -o 1 ";
  const ShellRun write = shell(mb + "-t 4 -r 2 " + pty.b() + " 2500");  // 2.5 bar on channel 1
  ASSERT_EQ(write.status, 0) << write.output;
  ModbusRegulatorMap map = ModbusRegulatorMap::generic10Bar();
  map.link.transport = ModbusTransport::Rtu;
  map.link.serial_port = pty.b();
  auto reg = client(map);
  double p = 0;
  for (int i = 0; i < 100 && std::abs(p - 250.0) > 0.3; ++i) {
    p = *reg->readPressureKPa(1);
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  EXPECT_NEAR(p, 250.0, 0.3);
  ASSERT_TRUE(reg->setPressureKPa(0, 77.7));
  reg.reset();  // let go of the port before mbpoll opens it
  const ShellRun setpoints = shell(mb + "-t 4 -r 1 -c 2 " + pty.b());
  EXPECT_EQ(mbpollValues(setpoints.output), (std::vector<std::string>{"777", "2500"}))
      << setpoints.output;
  EXPECT_EQ(server.stop(), 0);
}

TEST_F(SimRegulatorPeer, Float32MapReadByMbpoll) {
  SimRegulatorProcess server(
      {"--tcp", "127.0.0.1:0", "--map", configPath("regulator-float32.toml"), "--noise-kpa", "0"});
  ASSERT_TRUE(server.waitFor("Ctrl-C stops.")) << server.output();
  EXPECT_THAT(server.output(),
              HasSubstr("setpoints: holding registers 100, 102 (float32 CDAB bar)"));
  auto map = ModbusRegulatorMap::fromProfile(*loadRigProfile(configPath("regulator-float32.toml")));
  ASSERT_TRUE(map);
  map->link.port = server.port();
  auto reg = client(*map);
  ASSERT_TRUE(reg->setPressureKPa(0, 87.5));
  ASSERT_TRUE(reg->setPressureKPa(1, 150.0));
  // mbpoll's float: two registers, low word first unless -B ("CDAB").
  const ShellRun read = shell("mbpoll -m tcp -a 1 -1 -o 1 -p " + std::to_string(server.port()) +
                              " -t 4:float -r 101 -c 2 127.0.0.1");
  ASSERT_EQ(read.status, 0) << read.output;
  const auto values = mbpollValues(read.output);
  ASSERT_EQ(values.size(), 2u) << read.output;
  EXPECT_DOUBLE_EQ(std::stod(values[0]), 0.875);  // bar
  EXPECT_DOUBLE_EQ(std::stod(values[1]), 1.5);
  EXPECT_EQ(server.stop(), 0);
}

TEST_F(SimRegulatorPeer, FaultFlagsAsMbpollSeesThem) {
  {
    SimRegulatorProcess server({"--tcp", "127.0.0.1:0", "--exception", "6"});
    ASSERT_TRUE(server.waitFor("Ctrl-C stops.")) << server.output();
    const ShellRun read = shell("mbpoll -m tcp -a 1 -1 -o 1 -p " + std::to_string(server.port()) +
                                " -t 3 -r 1 127.0.0.1");
    EXPECT_THAT(read.output, HasSubstr("busy"));
    EXPECT_EQ(server.stop(), 0);
    EXPECT_THAT(server.output(), HasSubstr("1 exceptions"));
  }
  {
    SimRegulatorProcess server({"--tcp", "127.0.0.1:0", "--unit", "7"});
    ASSERT_TRUE(server.waitFor("Ctrl-C stops.")) << server.output();
    const std::string mb = "mbpoll -m tcp -1 -o 0.3 -p " + std::to_string(server.port());
    const ShellRun unit1 = shell(mb + " -a 1 -t 3 -r 1 127.0.0.1");
    EXPECT_THAT(unit1.output, HasSubstr("timed out"));
    const ShellRun unit7 = shell(mb + " -a 7 -t 3 -r 1 127.0.0.1");
    EXPECT_EQ(unit7.status, 0) << unit7.output;
    EXPECT_EQ(mbpollValues(unit7.output).size(), 1u) << unit7.output;
    EXPECT_EQ(server.stop(), 0);
  }
}

TEST_F(SimRegulatorPeer, BadInputExitsWithStatusTwo) {
  {
    SimRegulatorProcess p({"--tcp", "127.0.0.1"});
    EXPECT_EQ(p.wait(), 2);
    EXPECT_THAT(p.output(), HasSubstr("--tcp 127.0.0.1: write HOST:PORT"));
  }
  {
    SimRegulatorProcess p({"--tcp", "127.0.0.1:0", "--map", configPath("sim.toml")});
    EXPECT_EQ(p.wait(), 2);
    EXPECT_THAT(p.output(), HasSubstr("regulator.backend = \"sim\": not a Modbus regulator"));
  }
  {
    SimRegulatorProcess p({});
    EXPECT_EQ(p.wait(), 2);
    EXPECT_THAT(p.output(), HasSubstr("give --tcp HOST:PORT or --rtu /dev/pts/N"));
  }
  {
    SimRegulatorProcess p({"--rtu", "/nonexistent/tty"});
    EXPECT_EQ(p.wait(), 2);
    EXPECT_THAT(p.output(), HasSubstr("cannot open /nonexistent/tty"));
  }
}
