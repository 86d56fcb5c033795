#include "app/store/atomic_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>  // renameat2, RENAME_NOREPLACE
#include <cstring>
#include <ctime>
#include <filesystem>
#include <random>
#include <vector>

#include "hw/memory.hpp"

namespace collide::app {

namespace {

/// The folder holding `path` ("." for a bare file name), for fsync'ing the rename.
std::string folderOf(const std::string& path) {
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  return parent.empty() ? "." : parent.string();
}

/// An exclusive open-file-description lock on all of `fd`'s file (F_OFD_SETLK
/// or F_OFD_SETLKW): released when the descriptor is closed, also by the
/// kernel when the process dies. OFD locks rather than flock: HDF5 flock's the
/// files it opens, and the two kinds do not interfere. 0 or -1 (errno).
int lockWhole(int fd, int command) {
  struct flock lock {};
  lock.l_type = F_WRLCK;
  lock.l_whence = SEEK_SET;
  return ::fcntl(fd, command, &lock);
}

/// fsync a file or folder by name. Linux flushes the inode's dirty pages
/// whichever descriptor asks, so a fresh read-only descriptor is enough.
int syncPath(const std::string& path, int flags) {
  const int fd = ::open(path.c_str(), flags | O_CLOEXEC);
  if (fd < 0) return errno;
  int err = 0;
  if (::fsync(fd) != 0) err = errno;
  ::close(fd);
  return err;
}

/// Copies `from` into the open, empty `to_fd`. copy_file_range lets the
/// kernel copy (or share extents on XFS/btrfs) without a trip through user
/// space; read/write is the fallback across filesystems. Returns 0 or errno.
/// (std::filesystem::copy_file reports a short copy as a bare EIO, losing the
/// "disk full" a user needs to see.)
int copyInto(int from_fd, int to_fd) {
  bool kernel_copy = true;
  std::vector<char> buf;
  for (;;) {
    ssize_t n;
    if (kernel_copy) {
      n = ::copy_file_range(from_fd, nullptr, to_fd, nullptr, 1 << 30, 0);
      if (n < 0 && (errno == EXDEV || errno == ENOSYS || errno == EINVAL || errno == EOPNOTSUPP)) {
        kernel_copy = false;
        buf.resize(1 << 20);
        continue;
      }
      if (n < 0 && errno == EINTR) continue;
      if (n < 0) return errno;
      if (n == 0) return 0;
      continue;
    }
    n = ::read(from_fd, buf.data(), buf.size());
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return errno;
    if (n == 0) return 0;
    for (ssize_t done = 0; done < n;) {
      const ssize_t w = ::write(to_fd, buf.data() + done, static_cast<std::size_t>(n - done));
      if (w < 0 && errno == EINTR) continue;
      if (w < 0) return errno;
      done += w;
    }
  }
}

}  // namespace

Error ioError(int errno_value, const std::string& action, const std::string& path) {
  const std::string where = " " + action + " " + path;
  switch (errno_value) {
    case ENOSPC:
      return fail("no space left on device" + where +
                  ": free space or choose another folder (--out)");
    case EDQUOT:
      return fail("disk quota exceeded" + where + ": free space or choose another folder (--out)");
    case EFBIG:
      return fail("file too large (file size limit reached)" + where +
                  ": raise the limit (ulimit -f) or choose another folder (--out)");
    case EACCES:
    case EPERM:
      return fail("permission denied" + where +
                  ": check the folder's permissions or choose another folder (--out)");
    case EROFS: return fail("read-only file system" + where + ": choose another folder (--out)");
    case ENOENT: return fail("no such file or folder" + where + ": check the path");
    case EIO:
      return fail("input/output error" + where + ": the disk may be failing; check it (dmesg)");
    default: return fail(std::string(std::strerror(errno_value)) + where);
  }
}

Result<AtomicFile> AtomicFile::create(const std::string& final_path) {
  const std::filesystem::path final_fs(final_path);
  // O_EXCL with our own random suffix rather than mkstemp: mkstemp creates
  // mode 0600, while shot files should get the user's umask like any file.
  std::random_device seed;
  std::mt19937_64 rng(seed());
  static constexpr char kAlphabet[] = "abcdefghijklmnopqrstuvwxyz0123456789";
  std::string hidden_name = ".";
  hidden_name += final_fs.filename().string();
  const std::string prefix = (final_fs.parent_path() / hidden_name).string();
  for (int attempt = 0; attempt < 100; ++attempt) {
    std::string temp = prefix;
    temp.append(".tmp-");
    for (int i = 0; i < 6; ++i) temp.push_back(kAlphabet[rng() % (sizeof kAlphabet - 1)]);
    const int fd = ::open(temp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd >= 0) {
      // Held until the AtomicFile dies: the mark of a write in progress.
      lockWhole(fd, F_OFD_SETLK);
      return AtomicFile(final_path, temp, fd);
    }
    if (errno != EEXIST) return ioError(errno, "creating", final_path);
  }
  return fail("cannot create a temporary file next to " + final_path +
              ": 100 random names were all taken; remove the .tmp- files in that folder");
}

Result<AtomicFile> AtomicFile::createCopyOf(const std::string& source,
                                            const std::string& final_path) {
  auto temp = create(final_path);
  if (!temp) return temp.error();
  const int from = ::open(source.c_str(), O_RDONLY | O_CLOEXEC);
  if (from < 0) return ioError(errno, "reading", source);
  const int to = ::open(temp->tempPath().c_str(), O_WRONLY | O_TRUNC | O_CLOEXEC);
  if (to < 0) {
    const int err = errno;
    ::close(from);
    return ioError(err, "writing", final_path);
  }
  const int err = copyInto(from, to);
  ::close(from);
  const int close_err = ::close(to) != 0 ? errno : 0;
  if (err != 0 || close_err != 0) return ioError(err ? err : close_err, "copying", final_path);
  return temp;
}

AtomicFile::AtomicFile(AtomicFile&& other) noexcept
    : final_path_(std::move(other.final_path_)),
      temp_path_(std::move(other.temp_path_)),
      lock_fd_(other.lock_fd_) {
  other.temp_path_.clear();
  other.lock_fd_ = -1;
}

AtomicFile::~AtomicFile() {
  if (!temp_path_.empty()) ::unlink(temp_path_.c_str());
  if (lock_fd_ >= 0) ::close(lock_fd_);
}

int removeAbandonedTemps(const std::string& final_path) {
  namespace fs = std::filesystem;
  const fs::path final_fs(final_path);
  // Appended: GCC 12 warns falsely (-Wrestrict) on a string put before a
  // temporary one.
  std::string prefix = ".";
  prefix += final_fs.filename().string();
  prefix += ".tmp-";
  std::error_code ec;
  const fs::path folder = final_fs.parent_path().empty() ? fs::path(".") : final_fs.parent_path();
  int removed = 0;
  for (const auto& entry : fs::directory_iterator(folder, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.size() != prefix.size() + 6 || name.compare(0, prefix.size(), prefix) != 0) continue;
    const int fd = ::open(entry.path().c_str(), O_RDWR | O_CLOEXEC | O_NOFOLLOW);
    if (fd < 0) continue;
    struct stat st {};
    const bool ours_to_remove = lockWhole(fd, F_OFD_SETLK) == 0 && ::fstat(fd, &st) == 0 &&
                                S_ISREG(st.st_mode) &&
                                (st.st_size > 0 || ::time(nullptr) - st.st_mtime > 60);
    // Removed while locked: a writer that opens it meanwhile finds it gone.
    if (ours_to_remove && ::unlink(entry.path().c_str()) == 0) ++removed;
    ::close(fd);
  }
  return removed;
}

Result<FileLock> FileLock::acquire(const std::string& lock_path) {
  // O_RDWR: on NFS flock is emulated with POSIX locks, which need a writable descriptor.
  const int fd = ::open(lock_path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0666);
  if (fd < 0) return ioError(errno, "opening the lock file", lock_path);
  while (lockWhole(fd, F_OFD_SETLKW) != 0) {
    if (errno == EINTR) continue;
    const int err = errno;
    ::close(fd);
    return ioError(err, "locking", lock_path);
  }
  return FileLock(fd);
}

FileLock::~FileLock() {
  if (fd_ >= 0) ::close(fd_);
}

std::string storeLockPath(const std::string& folder) {
  return (std::filesystem::path(folder.empty() ? "." : folder) / ".collide-store.lock").string();
}

Status AtomicFile::syncTemp() {
  if (int err = syncPath(temp_path_, O_RDONLY)) return ioError(err, "writing", final_path_);
  return Ok{};
}

Status AtomicFile::syncFolder() {
  // The data is safe under its name already; failing to sync the folder only
  // risks the rename itself after a power cut, which is still worth reporting.
  if (int err = syncPath(folderOf(final_path_), O_RDONLY | O_DIRECTORY))
    return ioError(err, "syncing the folder of", final_path_);
  return Ok{};
}

Status AtomicFile::commit() {
  if (auto s = syncTemp(); !s) return s;
  if (::rename(temp_path_.c_str(), final_path_.c_str()) != 0)
    return ioError(errno, "renaming a temporary file to", final_path_);
  temp_path_.clear();
  return syncFolder();
}

Result<AtomicFile::Outcome> AtomicFile::commitIfAbsent() {
  if (auto s = syncTemp(); !s) return s.error();
  if (::renameat2(AT_FDCWD, temp_path_.c_str(), AT_FDCWD, final_path_.c_str(), RENAME_NOREPLACE) !=
      0) {
    const int err = errno;
    if (err == EEXIST) return Outcome::NameTaken;
    // File systems without RENAME_NOREPLACE (some network ones): a hard link
    // is created only if the name is free, equally atomically.
    if (err != EINVAL && err != ENOSYS) return ioError(err, "naming", final_path_);
    if (::link(temp_path_.c_str(), final_path_.c_str()) != 0) {
      if (errno == EEXIST) return Outcome::NameTaken;
      return ioError(errno, "naming", final_path_);
    }
    ::unlink(temp_path_.c_str());
  }
  temp_path_.clear();
  if (auto s = syncFolder(); !s) return s.error();
  return Outcome::Committed;
}

int writeAllToFd(int fd, const std::string& text) {
  for (std::size_t done = 0; done < text.size();) {
    const ssize_t w = ::write(fd, text.data() + done, text.size() - done);
    if (w < 0 && errno == EINTR) continue;
    if (w < 0) return errno;
    done += static_cast<std::size_t>(w);
  }
  return 0;
}

bool readAllFromFd(int fd, void* data, std::size_t size) {
  char* p = static_cast<char*>(data);
  while (size > 0) {
    const ssize_t n = ::read(fd, p, size);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    p += n;
    size -= static_cast<std::size_t>(n);
  }
  return true;
}

namespace {

Status writeThrough(const std::string& path, const std::string& text) {
  // No O_CREAT, no O_TRUNC: the node exists and is not ours to replace.
  const int fd = ::open(path.c_str(), O_WRONLY | O_CLOEXEC | O_NOCTTY);
  if (fd < 0) return ioError(errno, "opening", path);
  int err = writeAllToFd(fd, text);
  if (::close(fd) != 0 && err == 0) err = errno;
  if (err != 0) return ioError(err, "writing", path);
  return Ok{};
}

Status replaceRegular(const std::string& path, const std::string& text) {
  auto file = AtomicFile::create(path);
  if (!file) return file.error();
  const int fd = ::open(file->tempPath().c_str(), O_WRONLY | O_TRUNC | O_CLOEXEC);
  if (fd < 0) return ioError(errno, "writing", path);
  int err = writeAllToFd(fd, text);
  if (::close(fd) != 0 && err == 0) err = errno;
  if (err != 0) return ioError(err, "writing", path);
  return file->commit();
}

}  // namespace

Status writeTextFile(const std::string& path, const std::string& text) {
  namespace fs = std::filesystem;
  std::string target = path;
  // Follow a chain of links ourselves so a dangling link still gets its target
  // written (as a shell's `>` would) and the link itself stays.
  for (int hops = 0;; ++hops) {
    struct stat st {};
    if (::lstat(target.c_str(), &st) != 0) {
      if (errno == ENOENT) return replaceRegular(target, text);
      return ioError(errno, "checking", path);
    }
    if (S_ISLNK(st.st_mode)) {
      if (hops >= 40)
        return fail(path +
                    " is a chain of more than 40 symbolic links (a loop?): give a file name");
      std::error_code ec;
      const fs::path link_target = fs::read_symlink(target, ec);
      if (ec) return ioError(ec.value(), "reading the link", path);
      target =
          (link_target.is_absolute() ? link_target : fs::path(target).parent_path() / link_target)
              .string();
      continue;
    }
    if (S_ISREG(st.st_mode)) return replaceRegular(target, text);
    if (S_ISDIR(st.st_mode))
      return fail(path + " is a folder: give a file name, e.g. " +
                  (fs::path(path) / "results.json").string());
    if (S_ISFIFO(st.st_mode) || S_ISCHR(st.st_mode)) return writeThrough(target, text);
    if (S_ISBLK(st.st_mode))
      return fail(path +
                  " is a block device (a disk or partition): refusing to write to it; give "
                  "a file name");
    return fail(path + " is a socket or other special file: give a file name");
  }
}

Status checkFreeSpace(const std::string& folder, double bytes, const std::string& what) {
  struct statvfs fs {};
  if (::statvfs(folder.c_str(), &fs) != 0) return Ok{};
  const double free_bytes = static_cast<double>(fs.f_bavail) * static_cast<double>(fs.f_frsize);
  if (free_bytes >= bytes) return Ok{};
  return fail("not enough space to " + what + ": it needs " + hw::formatBytes(bytes) + ", " +
              hw::formatBytes(free_bytes) + " are free in " + folder +
              ": free space or choose another folder (--out)");
}

Status checkWritableFolder(const std::string& folder) {
  std::error_code ec;
  if (!std::filesystem::is_directory(folder, ec))
    return fail(folder + " is not a folder: give a folder for the shots (--out)");
  auto probe = AtomicFile::create((std::filesystem::path(folder) / ".write-check").string());
  if (!probe) return probe.error();
  return Ok{};  // the probe's destructor removes it
}

}  // namespace collide::app
