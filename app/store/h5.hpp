#pragma once
// Thin helpers over the HDF5 C API for app/'s shot files: one RAII handle for
// every kind of HDF5 id, the library's error stack turned into one-line
// messages, and one writer/reader helper per dataset or attribute kind.
// Internal to app/ (HDF5 is linked privately): include only from app/*.cpp.
//
// Writer and Reader keep the first error and ignore later calls ("sticky"
// error, like a std::ostream's fail bit), so a layout reads as a straight list
// of fields and the caller checks ok() once at the end.
#include <hdf5.h>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "analysis/result.hpp"

namespace collide::app::h5 {

/// Turns off HDF5's printing of its error stack to stderr; errors become
/// messages instead. HDF5's setting is per thread in thread-safe builds, so
/// every entry point calls this.
void silenceErrorPrinting();

/// What the HDF5 call that just failed reported: the innermost message, and
/// the errno it carried when the failure came from the operating system.
struct Cause {
  std::string text;
  int errno_value = 0;
};
Cause lastCause();

/// HDF5's Fletcher-32 checksum of `bytes` (the H5Z_FILTER_FLETCHER32 filter's:
/// 16-bit big-endian words summed in blocks of 360, an odd last byte as the
/// high half of a word). A chunk written past the filter pipeline (direct
/// chunk write) into a dataset with that filter must end in it, little-endian.
std::uint32_t fletcher32(const void* bytes, std::size_t size);

/// The variable-length strings one read of a file gave, in the order it asked
/// for them: how a contained read (ReadOptions::contained in shot_file.hpp)
/// keeps libhdf5's global-heap code out of the reading process. A damaged
/// global heap can make libhdf5 1.10 copy past its buffers without crashing
/// the child that reads first; the parent then replays the child's strings
/// instead of asking the library for them again. Every other read (numbers,
/// frames, fixed-length strings) does not touch the global heap.
struct VlenJournal {
  enum class Mode { Record, Replay };
  struct Read {
    bool failed = false;
    std::string cause;  // when failed: the library's message
    std::vector<std::string> strings;
  };
  Mode mode = Mode::Record;
  std::vector<Read> reads;
  std::size_t replayed = 0;

  /// Writes the recorded reads to the file descriptor `fd` (from its start).
  bool save(int fd) const;
  /// Reads what save() wrote; empty if `fd` does not hold a whole journal.
  static std::optional<VlenJournal> load(int fd);
};

/// While it lives, this thread's variable-length string reads are recorded
/// in, or replayed from, `journal` (by its mode). The caller holds the HDF5
/// lock (hdf5Mutex() in shot_file.cpp).
class JournalScope {
 public:
  explicit JournalScope(VlenJournal& journal);
  ~JournalScope();
  JournalScope(const JournalScope&) = delete;
  JournalScope& operator=(const JournalScope&) = delete;

 private:
  VlenJournal* previous_;
};

/// Owns one HDF5 id (file, group, dataset, dataspace, datatype, attribute,
/// property list) and closes it with the matching H5?close.
class Handle {
 public:
  using Closer = herr_t (*)(hid_t);
  Handle() = default;
  Handle(hid_t id, Closer closer) : id_(id), closer_(closer) {}
  Handle(Handle&& o) noexcept : id_(o.id_), closer_(o.closer_) { o.id_ = H5I_INVALID_HID; }
  Handle& operator=(Handle&& o) noexcept;
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  ~Handle() { close(); }

  hid_t get() const { return id_; }
  bool valid() const { return id_ >= 0; }
  /// Closes now; negative if HDF5 reports an error (for files: the final flush).
  herr_t close();

 private:
  hid_t id_ = H5I_INVALID_HID;
  Closer closer_ = nullptr;
};

/// Variable-length UTF-8 string type, the one string type shot files use.
Handle stringType();

/// The HDF5 memory type of a C++ arithmetic type.
template <class T>
hid_t nativeType();

/// Marker for "any size" in Reader's expected dimensions.
inline constexpr hsize_t kAnySize = static_cast<hsize_t>(-1);

class Writer {
 public:
  /// `display_path`: the file name users know (not the temporary one).
  Writer(hid_t file, std::string display_path)
      : file_(file), display_path_(std::move(display_path)) {}

  bool ok() const { return ok_; }
  const Error& error() const { return error_; }
  /// Records the failure of an HDF5 call doing `what` (e.g. "writing /frames/id").
  void failHdf5(const std::string& what);
  /// Records a failure that is not HDF5's (already a full message).
  void fail(Error error);

  void group(const std::string& path);
  void attribute(const std::string& object, const char* name, const std::string& value);
  void attribute(const std::string& object, const char* name, std::int32_t value);
  /// A numeric dataset of shape `dims` ({} = scalar) with a `units` attribute.
  template <class T>
  void dataset(const std::string& path, const T* data, const std::vector<hsize_t>& dims,
               const char* units);
  template <class T>
  void scalar(const std::string& path, T value, const char* units) {
    dataset(path, &value, {}, units);
  }
  template <class T>
  void vector(const std::string& path, const std::vector<T>& values, const char* units) {
    dataset(path, values.data(), {values.size()}, units);
  }
  /// One text (scalar string dataset) with `units` = "" and a `media_type`.
  void text(const std::string& path, const std::string& value, const char* media_type);
  /// A 1-D array of strings with `units` = "".
  void strings(const std::string& path, const std::vector<std::string>& values);
  /// Sets the string attribute `name` on an open object (dataset or group).
  void attributeOn(hid_t object, const std::string& object_path, const char* name,
                   const std::string& value);
  /// Creates the dataset `path` (with creation properties `dcpl`, e.g. chunking)
  /// for the caller to fill; invalid after a failure.
  Handle createDataset(const std::string& path, hid_t type, const std::vector<hsize_t>& dims,
                       hid_t dcpl = H5P_DEFAULT);

 private:
  hid_t file_;
  std::string display_path_;
  bool ok_ = true;
  Error error_;
};

class Reader {
 public:
  Reader(hid_t file, std::string display_path)
      : file_(file), display_path_(std::move(display_path)) {}

  bool ok() const { return ok_; }
  const Error& error() const { return error_; }
  void failHdf5(const std::string& what);
  void failHdf5(const std::string& what, const Cause& cause);
  /// True if `object` has attribute `name`; otherwise records why not: absent
  /// ("lacks attribute") or unreadable (corrupt).
  bool attributeExists(const std::string& object, const char* name);
  void fail(Error error);

  /// Whether a group or dataset exists at `path` (every component checked).
  bool exists(const std::string& path);
  /// Opens a dataset that must exist (with access properties `dapl`, e.g. a
  /// chunk cache); failure names it as missing.
  Handle openDataset(const std::string& path, hid_t dapl = H5P_DEFAULT);

  std::string stringAttribute(const std::string& object, const char* name);
  std::int32_t intAttribute(const std::string& object, const char* name);
  /// Reads a numeric dataset whose shape must match `expected` (kAnySize = any
  /// length on that axis); `dims` receives the actual shape.
  template <class T>
  std::vector<T> dataset(const std::string& path, const std::vector<hsize_t>& expected,
                         std::vector<hsize_t>* dims = nullptr);
  template <class T>
  T scalar(const std::string& path) {
    std::vector<T> v = dataset<T>(path, {});
    return v.empty() ? T{} : v.front();
  }
  template <class T>
  std::vector<T> vector(const std::string& path) {
    return dataset<T>(path, {kAnySize});
  }
  std::string text(const std::string& path);
  std::vector<std::string> strings(const std::string& path);

 private:
  /// Reads strings from a dataset of `expected_rank` (0 or 1).
  std::vector<std::string> readStrings(const std::string& path, int expected_rank);
  /// Attribute `name` of `object`, open, if it holds one value of class
  /// `cls` (fails, saying it should be `one_what`, if not).
  struct OneValue {
    Handle attr, type, space;
  };
  std::optional<OneValue> oneValueAttribute(const std::string& object, const char* name,
                                            H5T_class_t cls, const char* one_what);
  /// Whether the `count` elements of `element_bytes` dataset `d` declares
  /// are data the file holds (fails naming `path` if not), so that no
  /// dimension in a damaged or hostile header sizes an allocation.
  bool heldInFile(hid_t d, const std::string& path, hsize_t count, std::size_t element_bytes);
  /// False (failing with why) if a variable-length string dataset's
  /// references point at heap objects that libhdf5 would read past its
  /// tables for; see stringReferenceDamage.
  bool referencesSound(hid_t d, hid_t type, const std::string& path, std::size_t count);

  hid_t file_;
  std::string display_path_;
  bool ok_ = true;
  Error error_;
};

}  // namespace collide::app::h5
