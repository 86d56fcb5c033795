// The reader process behind contained reads (app/store/reader_process.hpp):
// one process serves many reads; a crash or a loop is blamed on a file only
// when a fresh process gives it; the process holds none of the program's
// descriptors and does not outlive the program. The reads here are stand-ins
// (functions that crash, spin or sleep on a given name), so each outcome is
// certain; corrupt_shot_test.cpp reads real damaged files.
#include "app/store/reader_process.hpp"

#include <fcntl.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstdlib>
#include <fstream>
#include <thread>

#include "app/store/address_sanitizer.hpp"
#include "app/store/save.hpp"
#include "app/store/shot_file.hpp"
#include "tests/app/shot_fixtures.hpp"

namespace collide::testing {
namespace {

using app::ProbeResult;
using End = ProbeResult::End;

// State a stand-in read leaves in the reader process, as a damaged file could
// leave the library's.
bool g_poisoned = false;

// A heap read past the end, in this program's code (only asked for under
// AddressSanitizer, which stops it).
void readPastTheEnd() {
  char* bytes = new char[8];
  volatile int past = 8;
  volatile char c = bytes[past];
  (void)c;
  delete[] bytes;
}

// "crash": the process ends (exit status 3); "poison": later reads in the same
// process crash; "spin": works for ever; "sleep": sits idle for ever;
// "refuse...": an error naming the file; any other name reads fine.
std::optional<std::string> standIn(const std::string& path, bool /*frames*/) {
  if (path == "crash" || g_poisoned) ::_exit(3);
  if (path == "poison") g_poisoned = true;
  if (path == "spin") {
    volatile unsigned long i = 0;
    for (;;) i = i + 1;
  }
  if (path == "sleep")
    for (;;) ::pause();
  if (path.rfind("refuse", 0) == 0) return path + " is not a shot file";
  if (path == "overflow") readPastTheEnd();
  if (path == "abort") std::abort();
  return std::nullopt;
}

ProbeResult probe(const std::string& name, double limit_s = 5.0) {
  return app::probeInReaderProcess(name, false, limit_s, standIn);
}

double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// Whether process `pid` is gone (or a zombie no one reaped yet).
bool ended(pid_t pid) {
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string text((std::istreambuf_iterator<char>(stat)), {});
  const auto close = text.rfind(')');
  return close == std::string::npos || text.substr(close + 2, 1) == "Z";
}

bool endsWithin(pid_t pid, double seconds) {
  const auto start = std::chrono::steady_clock::now();
  while (!ended(pid)) {
    if (secondsSince(start) > seconds) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return true;
}

TEST(ReaderProcess, OneProcessServesManyReads) {
  ASSERT_EQ(probe("crash").end, End::Crashed);  // whatever ran before, none runs now
  const long started = app::readerProcessStats().started;
  for (int i = 0; i < 50; ++i) {
    const ProbeResult r = probe("fine-" + std::to_string(i));
    ASSERT_EQ(r.end, End::Finished) << "read " << i;
    EXPECT_TRUE(r.strings.has_value()) << "read " << i;
    EXPECT_FALSE(r.error.has_value()) << "read " << i;
  }
  EXPECT_EQ(app::readerProcessStats().started, started + 1);
}

TEST(ReaderProcess, TheReadsErrorComesBackWhole) {
  const std::string name = "refuse-" + std::string(100000, 'x');  // more than one socket write
  const ProbeResult r = probe(name);
  ASSERT_EQ(r.end, End::Finished);
  ASSERT_TRUE(r.error.has_value());
  EXPECT_EQ(*r.error, name + " is not a shot file");
  EXPECT_FALSE(probe("fine").error.has_value()) << "the next answer starts where this one ended";
}

TEST(ReaderProcess, ACrashInAFreshProcessIsTheFiles) {
  probe("warm-up");  // the crash below comes in a process that read before
  const ProbeResult r = probe("crash");
  EXPECT_EQ(r.end, End::Crashed);
  EXPECT_EQ(r.how, "exit status 3");
  EXPECT_EQ(app::readerProcessStats().pid, -1) << "the crashed process is reaped";
  EXPECT_EQ(probe("after").end, End::Finished) << "the next read gets a new process";
}

// A memory error in our own reader must not pass for a damaged file (the
// library's, by a libhdf5 frame on the stack: CorruptShotHeapOverflow).
TEST(ReaderProcess, AMemoryErrorInOurOwnCodeIsNotCalledTheFiles) {
#ifndef COLLIDE_ASAN
  GTEST_SKIP() << "needs AddressSanitizer (./collide.sh sanitize runs it)";
#else
  probe("warm-up");
  const ProbeResult r = probe("overflow");
  EXPECT_EQ(r.end, End::OwnCodeFailed) << r.how;
  EXPECT_EQ(probe("after").end, End::Finished);
#endif
}

// The program's own SIGABRT handler (libFuzzer installs one that writes the
// current input as a crash file) must not run in the reader.
int g_abort_marker = -1;
TEST(ReaderProcess, AnAbortEndsTheReaderNotThroughTheProgramsHandler) {
  int marker[2];
  ASSERT_EQ(::pipe(marker), 0);
  g_abort_marker = marker[1];
  struct sigaction handler {
  }, previous{};
  handler.sa_handler = [](int) {
    (void)!::write(g_abort_marker, "H", 1);
    ::_exit(0);
  };
  ASSERT_EQ(::sigaction(SIGABRT, &handler, &previous), 0);
  probe("crash");  // the next reader is forked with the handler installed
  const ProbeResult r = probe("abort");
  ::sigaction(SIGABRT, &previous, nullptr);
  ::close(marker[1]);
  EXPECT_EQ(r.end, End::Crashed);
  EXPECT_EQ(r.how, "SIGABRT");
  char c = 0;
  EXPECT_EQ(::read(marker[0], &c, 1), 0) << "the program's handler ran in the reader";
  ::close(marker[0]);
}

TEST(ReaderProcess, ACrashLeftByAnEarlierFileIsNotBlamedOnTheNextOne) {
  probe("warm-up");
  ASSERT_EQ(probe("poison").end, End::Finished);
  const long started = app::readerProcessStats().started;
  const ProbeResult r = probe("innocent");
  EXPECT_EQ(r.end, End::Finished) << r.how;
  EXPECT_EQ(app::readerProcessStats().started, started + 1) << "retried in a fresh process";
}

TEST(ReaderProcess, AReadThatWorksPastItsLimitIsStoppedAndCalledALoop) {
  probe("crash");  // a fresh process: one try, not two
  const auto start = std::chrono::steady_clock::now();
  const ProbeResult r = probe("spin", 0.5);
  EXPECT_EQ(r.end, End::Looped);
  EXPECT_GE(secondsSince(start), 0.5);
  EXPECT_LT(secondsSince(start), 5.0);
  EXPECT_EQ(probe("after").end, End::Finished);
}

TEST(ReaderProcess, AProcessThatSitsIdleIsStalledNotALoop) {
  probe("crash");
  EXPECT_EQ(probe("sleep", 0.5).end, End::Stalled);
  EXPECT_EQ(probe("after").end, End::Finished);
}

TEST(ReaderProcess, TheProcessHoldsNoneOfTheProgramsDescriptors) {
  int ends[2];
  ASSERT_EQ(::pipe(ends), 0);  // no O_CLOEXEC: a plain fork would keep both
  probe("crash");              // the next read forks a new process, after the pipe
  ASSERT_EQ(probe("fine").end, End::Finished);
  ASSERT_GT(app::readerProcessStats().pid, 0);
  ::close(ends[1]);
  // The program closed the only write end: the read end sees its end at once.
  pollfd p{.fd = ends[0], .events = POLLIN, .revents = 0};
  ASSERT_EQ(::poll(&p, 1, 2000), 1) << "the reader process still holds the pipe's write end";
  char c = 0;
  EXPECT_EQ(::read(ends[0], &c, 1), 0);
  ::close(ends[0]);
}

// The program is killed while its reader works on a read that never ends:
// the reader must not go on spinning.
TEST(ReaderProcess, ItDoesNotOutliveAKilledProgram) {
  int report[2];
  ASSERT_EQ(::pipe(report), 0);
  const pid_t program = ::fork();
  if (program == 0) {
    ::close(report[0]);
    probe("fine");
    const pid_t reader = app::readerProcessStats().pid;
    (void)!::write(report[1], &reader, sizeof reader);
    probe("spin", 60.0);
    ::_exit(0);
  }
  ::close(report[1]);
  pid_t reader = -1;
  ASSERT_EQ(::read(report[0], &reader, sizeof reader), static_cast<ssize_t>(sizeof reader));
  ::close(report[0]);
  ASSERT_GT(reader, 0);
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // it is spinning now
  EXPECT_FALSE(ended(reader));
  ::kill(program, SIGKILL);
  ::waitpid(program, nullptr, 0);
  EXPECT_TRUE(endsWithin(reader, 5.0)) << "reader process " << reader << " outlived the program";
}

// Contained reads of real shot files: a folder of them costs one process.
TEST(ReaderProcess, ContainedReadsOfAFolderShareOneProcess) {
  ScratchDir dir;
  std::vector<std::string> paths;
  for (int i = 0; i < 12; ++i) {
    ShotSpec spec;
    spec.id = "20260314-101500-" + std::string(i < 10 ? "000" : "00") + std::to_string(i);
    ASSERT_TRUE(app::saveShot(dir.path(), makeShot(spec)).ok());
    paths.push_back(dir.file(spec.id + ".h5"));
  }
  probe("crash");
  const auto before = app::readerProcessStats();
  for (const auto& path : paths) {
    auto shot = app::readShot(path, {.frames = true, .contained = true});
    ASSERT_TRUE(shot.ok()) << shot.error().message;
    EXPECT_FALSE(shot->burst.frames.empty());
  }
  const auto after = app::readerProcessStats();
  EXPECT_EQ(after.started, before.started + 1);
  EXPECT_EQ(after.reads, before.reads + 12);
}

}  // namespace
}  // namespace collide::testing
