#pragma once
// The helper process behind a contained read (ReadOptions::contained in
// shot_file.hpp): a child forked once that reads shot files for the program,
// so that a file which crashes or hangs libhdf5 costs the child, not the
// program, and a folder of files costs one fork rather than one per file.

#include <sys/types.h>

#include <optional>
#include <string>

#include "app/store/h5.hpp"

namespace collide::app {

/// How a read in the reader process ended.
struct ProbeResult {
  enum class End {
    Finished,  ///< the read returned (a shot or an error: the caller reads again to know)
    Crashed,   ///< the library crashed on the file, in a freshly started process
    Looped,    ///< the read worked past its time limit, in a freshly started process
    Stalled,   ///< the process sat idle past the time limit (not the file's fault)
    /// Sanitizer builds only: AddressSanitizer or UBSan found an error in this
    /// program's code (no libhdf5 frame on the stack): a bug, not the file's.
    OwnCodeFailed,
  };
  End end = End::Finished;
  std::string how;  ///< Crashed: "SIGSEGV", "exit status 1", ...
  /// Finished: the variable-length strings the read asked for, to replay in
  /// the caller's own read. Empty when they could not be handed over, or when
  /// no process could be started (the caller then reads unprotected).
  std::optional<h5::VlenJournal> strings;
  /// Finished: the error the read gave, if it gave one (the caller need not
  /// read the file again to know it).
  std::optional<std::string> error;
};

/// What the reader process runs for one request: reads the shot file `path`
/// (its frames too when `frames`) and returns the read's error, or nothing if
/// it gave a shot. Called with a recording JournalScope open. Any function of
/// the program: it is sent to the process by its address.
using ReadWork = std::optional<std::string> (*)(const std::string& path, bool frames);

/// Has the reader process read `path` with `work`, starting the process if
/// none runs. A crash or a read past `limit_s` seconds in a process that had
/// read other files first is tried again in a fresh one, so a library state
/// left by an earlier file is never blamed on this one. The caller holds the
/// HDF5 lock (hdf5Mutex() in shot_file.cpp): no other thread of ours is
/// inside the library when the process is forked.
ProbeResult probeInReaderProcess(const std::string& path, bool frames, double limit_s,
                                 ReadWork work);

/// Counts, for tests and benchmarks.
struct ReaderProcessStats {
  long started = 0;  ///< processes forked since the program started
  long reads = 0;    ///< requests sent
  pid_t pid = -1;    ///< the running process, or -1
};
ReaderProcessStats readerProcessStats();

}  // namespace collide::app
