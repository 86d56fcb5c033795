#pragma once
// Files that appear under their real name only once complete: written to a
// temporary name in the same folder, flushed to disk, then renamed. A crash or
// a full disk never leaves a half-written file under the real name.
#include <string>

#include "analysis/result.hpp"

namespace collide::app {

/// One line for the user from an errno value: what went wrong while `action`
/// ("writing", "reading", ...) `path`, and what to do. For example
/// ioError(ENOSPC, "writing", "shots/x.h5") gives
/// "no space left on device writing shots/x.h5: free space or choose another folder (--out)".
Error ioError(int errno_value, const std::string& action, const std::string& path);

/// A temporary file next to `finalPath()` that becomes `finalPath()` on
/// commit(). Until then it is hidden (".name.tmp-XXXXXX") and the destructor
/// removes it. While it lives it holds an exclusive lock (an OFD lock) on the temporary
/// file, so removeAbandonedTemps() can tell a write in progress (locked) from
/// one whose process was killed (the kernel dropped its lock). Move-only; one
/// thread at a time.
class AtomicFile {
 public:
  /// Creates the (empty) temporary file. Errors: the folder is missing or not
  /// writable, the disk is full.
  static Result<AtomicFile> create(const std::string& final_path);
  /// Creates the temporary file as a copy of `source` (usually the final path
  /// itself, to update a file without touching it until commit()).
  static Result<AtomicFile> createCopyOf(const std::string& source, const std::string& final_path);

  AtomicFile(AtomicFile&& other) noexcept;
  AtomicFile& operator=(AtomicFile&&) = delete;
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;
  ~AtomicFile();

  const std::string& tempPath() const { return temp_path_; }
  const std::string& finalPath() const { return final_path_; }

  /// fsync's the temporary file (the caller has closed its own handles), renames
  /// it to the final name, and fsync's the folder so the rename survives a
  /// power cut. Errors (e.g. a delayed-allocation ENOSPC reported by fsync)
  /// name the final path; on error the temporary file is still removed by the
  /// destructor.
  Status commit();

  /// fsync's the temporary file ahead of commit() (which then has little
  /// left to flush), e.g. to keep that out of a lock held around commit().
  Status flush() { return syncTemp(); }

  /// What commitIfAbsent() did.
  enum class Outcome { Committed, NameTaken };

  /// As commit(), but never replaces anything: when `finalPath()` already
  /// exists (another shot, another writer that got there first) nothing is
  /// renamed, NameTaken is returned and the temporary file is left for the
  /// destructor to remove. The check and the rename are one atomic step
  /// (renameat2 RENAME_NOREPLACE; link + unlink where the file system lacks
  /// it), so two processes saving under one name cannot both succeed.
  Result<Outcome> commitIfAbsent();

 private:
  /// fsync's the temporary file; errors name the final path.
  Status syncTemp();
  /// fsync's the folder of the final path after a rename.
  Status syncFolder();

  AtomicFile(std::string final_path, std::string temp_path, int lock_fd)
      : final_path_(std::move(final_path)), temp_path_(std::move(temp_path)), lock_fd_(lock_fd) {}

  std::string final_path_;
  std::string temp_path_;  ///< empty once committed or moved from
  int lock_fd_ = -1;       ///< holds the flock on the temporary file; -1 once moved from
};

/// Removes the temporary files of writes to `final_path` that will never
/// finish (".name.tmp-XXXXXX" whose writer was killed: a SIGKILL, a node
/// that went down, a Slurm time limit): those no live AtomicFile holds
/// locked. An empty one is removed only once a minute old (its writer may be
/// between creating and locking it). Returns how many were removed.
int removeAbandonedTemps(const std::string& final_path);

/// An exclusive advisory lock (an open-file-description lock) on a lock file,
/// held until destruction. Works between processes, between threads (each
/// lock opens the file) and, on NFS, between machines.
class FileLock {
 public:
  /// Blocks until the lock on `lock_path` (created if missing) is held.
  /// Errors: the file cannot be created or opened (folder read-only).
  static Result<FileLock> acquire(const std::string& lock_path);
  FileLock(FileLock&& other) noexcept : fd_(other.fd_) { other.fd_ = -1; }
  FileLock& operator=(FileLock&&) = delete;
  FileLock(const FileLock&) = delete;
  FileLock& operator=(const FileLock&) = delete;
  ~FileLock();

 private:
  explicit FileLock(int fd) : fd_(fd) {}
  int fd_ = -1;
};

/// The lock file that serialises storing results into the shots of `folder`
/// (file and catalog row, saveResults), between threads, processes and
/// machines sharing the folder: "<folder>/.collide-store.lock". Created by the
/// first store; it stays in the folder (an empty file).
std::string storeLockPath(const std::string& folder);

/// Writes `text` to `path` as a user asked for an output file (--json, fit
/// output, a profile): a new or regular file is replaced atomically (complete
/// or not at all); a symbolic link is followed and its target written the same
/// way (the link stays a link); a FIFO or character device (a pipe, a
/// terminal, /dev/null, /dev/full) is written through, never replaced by a
/// file. Refused with a message naming `path`: a folder, a block device (a
/// disk), a socket, a link loop. Errors from writing name `path` and say what
/// to do (disk full, permission denied, ...).
Status writeTextFile(const std::string& path, const std::string& text);

/// Writes all of `text` to the open descriptor `fd` (short writes and EINTR
/// retried); 0, or the errno of the write that failed.
int writeAllToFd(int fd, const std::string& text);

/// Reads exactly `size` bytes from the open descriptor `fd` (short reads and
/// EINTR retried); false at the end of the input or on an error.
bool readAllFromFd(int fd, void* data, std::size_t size);

/// Ok if `folder` has at least `bytes` free for this user; otherwise "not
/// enough space to <what>: it needs X, Y are free: free space or choose
/// another folder (--out)". Ok too when the free space cannot be read (the
/// write itself will then say what is wrong).
Status checkFreeSpace(const std::string& folder, double bytes, const std::string& what);

/// Ok if files can be created in `folder` (an existing folder): a hidden
/// temporary file is created and removed. Errors name the folder and say what
/// to do (permissions, read-only file system, not a folder).
Status checkWritableFolder(const std::string& folder);

}  // namespace collide::app
