#include "app/store/h5.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <mutex>
#include <optional>
#include <sstream>

#include "app/store/atomic_file.hpp"
#include "app/store/heap_check_driver.hpp"
#include "hw/memory.hpp"

// Shot files are read and written from several threads (GUI browser, saver,
// analysis) with no lock of our own: that relies on HDF5's global lock.
#ifndef H5_HAVE_THREADSAFE
#error "collide needs a thread-safe HDF5 build (Debian's libhdf5-dev is one)"
#endif

namespace collide::app::h5 {

void silenceErrorPrinting() {
  // Before the library's first call: no clean-up at exit. HDF5 1.10's exit
  // handler re-closes any file whose H5Fclose failed (a disk that filled up
  // during the final flush) and crashes on it (SIGSEGV after a clean error
  // message). Every file here is closed by its owner, and a file whose close
  // failed is a temporary one that is deleted anyway.
  static std::once_flag once;
  std::call_once(once, [] { H5dont_atexit(); });
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
}

std::uint32_t fletcher32(const void* bytes, std::size_t size) {
  const auto* p = static_cast<const std::uint8_t*>(bytes);
  std::uint32_t sum1 = 0, sum2 = 0;
  const auto fold = [&] {
    sum1 = (sum1 & 0xffff) + (sum1 >> 16);
    sum2 = (sum2 & 0xffff) + (sum2 >> 16);
  };
  // Blocks of at most 360 words keep the running sums within 32 bits.
  for (std::size_t words = size / 2; words > 0;) {
    const std::size_t block = std::min<std::size_t>(words, 360);
    words -= block;
    for (std::size_t k = 0; k < block; ++k, p += 2) {
      sum1 += (static_cast<std::uint32_t>(p[0]) << 8) | p[1];
      sum2 += sum1;
    }
    fold();
  }
  if (size % 2) {
    sum1 += static_cast<std::uint32_t>(*p) << 8;
    sum2 += sum1;
    fold();
  }
  fold();
  return (sum2 << 16) | sum1;
}

Cause lastCause() {
  struct Walk {
    Cause cause;
    bool first = true;
  } walk;
  // Upward = innermost (where the failure started) first: its message is the
  // most specific ("truncated file: eof = ..."), and the operating system's
  // errno, when there is one, is reported down there too.
  H5Ewalk2(
      H5E_DEFAULT, H5E_WALK_UPWARD,
      [](unsigned, const H5E_error2_t* e, void* data) -> herr_t {
        auto& w = *static_cast<Walk*>(data);
        std::string desc = e->desc ? e->desc : "";
        if (desc.empty()) {
          char buf[256] = {};
          H5Eget_msg(e->min_num, nullptr, buf, sizeof buf);
          desc = buf;
        }
        if (w.first) {
          w.cause.text = desc;
          w.first = false;
        }
        if (w.cause.errno_value == 0) {
          const auto at = desc.find("errno = ");
          if (at != std::string::npos) w.cause.errno_value = std::atoi(desc.c_str() + at + 8);
        }
        return 0;
      },
      &walk);
  H5Eclear2(H5E_DEFAULT);
  if (walk.cause.text.empty()) walk.cause.text = "unknown HDF5 error";
  return walk.cause;
}

Handle& Handle::operator=(Handle&& o) noexcept {
  if (this != &o) {
    close();
    id_ = o.id_;
    closer_ = o.closer_;
    o.id_ = H5I_INVALID_HID;
  }
  return *this;
}

herr_t Handle::close() {
  herr_t status = 0;
  if (id_ >= 0 && closer_) status = closer_(id_);
  id_ = H5I_INVALID_HID;
  return status;
}

Handle stringType() {
  Handle type(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(type.get(), H5T_VARIABLE);
  H5Tset_cset(type.get(), H5T_CSET_UTF8);
  return type;
}

template <>
hid_t nativeType<double>() {
  return H5T_NATIVE_DOUBLE;
}
template <>
hid_t nativeType<std::int32_t>() {
  return H5T_NATIVE_INT32;
}
template <>
hid_t nativeType<std::int64_t>() {
  return H5T_NATIVE_INT64;
}
template <>
hid_t nativeType<std::uint64_t>() {
  return H5T_NATIVE_UINT64;
}
template <>
hid_t nativeType<std::uint8_t>() {
  return H5T_NATIVE_UINT8;
}
template <>
hid_t nativeType<std::uint16_t>() {
  return H5T_NATIVE_UINT16;
}

namespace {

std::string shapeText(const std::vector<hsize_t>& dims) {
  std::ostringstream s;
  s << '[';
  for (std::size_t i = 0; i < dims.size(); ++i) {
    if (i) s << ", ";
    if (dims[i] == kAnySize)
      s << "any";
    else
      s << dims[i];
  }
  s << ']';
  return s.str();
}

Handle dataspace(const std::vector<hsize_t>& dims) {
  if (dims.empty()) return Handle(H5Screate(H5S_SCALAR), H5Sclose);
  return Handle(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr), H5Sclose);
}

hsize_t elementCount(const std::vector<hsize_t>& dims) {
  hsize_t n = 1;
  for (hsize_t d : dims) n *= d;
  return n;
}

thread_local VlenJournal* active_journal = nullptr;

/// Reads `count` variable-length strings through `read`, or takes them from
/// the active journal (see VlenJournal): recorded when it records, replayed
/// (without asking the library) when it replays.
std::optional<Cause> readVariableStrings(hid_t space, std::size_t count,
                                         const std::function<herr_t(hid_t, void*)>& read,
                                         std::vector<std::string>& out) {
  VlenJournal* journal = active_journal;
  if (journal && journal->mode == VlenJournal::Mode::Replay) {
    if (journal->replayed >= journal->reads.size() ||
        journal->reads[journal->replayed].strings.size() != count)
      return Cause{"its strings did not read the same way twice (a damaged global heap)"};
    const auto& recorded = journal->reads[journal->replayed++];
    if (recorded.failed) return Cause{recorded.cause};
    out = recorded.strings;
    return std::nullopt;
  }
  Handle mem = stringType();
  std::vector<char*> ptrs(count, nullptr);
  if (read(mem.get(), ptrs.data()) < 0) {
    Cause cause = lastCause();
    if (journal) journal->reads.push_back({true, cause.text, std::vector<std::string>(count)});
    return cause;
  }
  for (std::size_t i = 0; i < count; ++i) out[i] = ptrs[i] ? ptrs[i] : "";
  H5Dvlen_reclaim(mem.get(), space, H5P_DEFAULT, ptrs.data());
  if (journal) journal->reads.push_back({false, {}, out});
  return std::nullopt;
}

/// Reads `count` strings stored with `file_type` (variable or fixed length)
/// through `read(memory_type, buffer)`, which wraps H5Aread or H5Dread.
/// Returns the cause on failure, taken before closing the memory type (every
/// HDF5 call, H5Tclose included, clears the error stack).
std::optional<Cause> readStringsOfType(hid_t file_type, hid_t space, std::size_t count,
                                       const std::function<herr_t(hid_t, void*)>& read,
                                       std::vector<std::string>& out) {
  out.assign(count, {});
  if (count == 0) return std::nullopt;
  if (H5Tis_variable_str(file_type) > 0) return readVariableStrings(space, count, read, out);
  // Fixed-length strings (what MATLAB's h5writeatt writes): NUL-padded.
  const std::size_t size = H5Tget_size(file_type);
  Handle mem(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(mem.get(), size);
  std::vector<char> buf(size * count);
  if (read(mem.get(), buf.data()) < 0) return lastCause();
  for (std::size_t i = 0; i < count; ++i) {
    const char* s = buf.data() + i * size;
    out[i].assign(s, strnlen(s, size));
  }
  return std::nullopt;
}

}  // namespace

// ---------------------------------------------------------------- Writer

void Writer::failHdf5(const std::string& what) {
  const Cause cause = lastCause();
  if (!ok_) return;
  if (cause.errno_value != 0)
    fail(ioError(cause.errno_value, "writing", display_path_));
  else
    fail(collide::fail("cannot write " + display_path_ + ": HDF5 failed " + what + " (" +
                       cause.text + ")"));
}

void Writer::fail(Error error) {
  if (!ok_) return;
  ok_ = false;
  error_ = std::move(error);
}

void Writer::group(const std::string& path) {
  if (!ok_) return;
  Handle g(H5Gcreate2(file_, path.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
  if (!g.valid()) failHdf5("creating group " + path);
}

void Writer::attributeOn(hid_t object, const std::string& object_path, const char* name,
                         const std::string& value) {
  if (!ok_) return;
  Handle type = stringType();
  Handle space = dataspace({});
  Handle attr(H5Acreate2(object, name, type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT),
              H5Aclose);
  const char* p = value.c_str();
  if (!attr.valid() || H5Awrite(attr.get(), type.get(), &p) < 0)
    failHdf5("writing attribute " + std::string(name) + " of " + object_path);
}

void Writer::attribute(const std::string& object, const char* name, const std::string& value) {
  if (!ok_) return;
  Handle obj(H5Oopen(file_, object.c_str(), H5P_DEFAULT), H5Oclose);
  if (!obj.valid()) return failHdf5("opening " + object);
  attributeOn(obj.get(), object, name, value);
}

void Writer::attribute(const std::string& object, const char* name, std::int32_t value) {
  if (!ok_) return;
  Handle space = dataspace({});
  Handle attr(H5Acreate_by_name(file_, object.c_str(), name, H5T_STD_I32LE, space.get(),
                                H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
              H5Aclose);
  if (!attr.valid() || H5Awrite(attr.get(), H5T_NATIVE_INT32, &value) < 0)
    failHdf5("writing attribute " + std::string(name) + " of " + object);
}

Handle Writer::createDataset(const std::string& path, hid_t type, const std::vector<hsize_t>& dims,
                             hid_t dcpl) {
  if (!ok_) return {};
  Handle space = dataspace(dims);
  Handle d(H5Dcreate2(file_, path.c_str(), type, space.get(), H5P_DEFAULT, dcpl, H5P_DEFAULT),
           H5Dclose);
  if (!d.valid()) failHdf5("creating " + path);
  return d;
}

template <class T>
void Writer::dataset(const std::string& path, const T* data, const std::vector<hsize_t>& dims,
                     const char* units) {
  Handle d = createDataset(path, nativeType<T>(), dims);
  if (!ok_) return;
  if (elementCount(dims) > 0 &&
      H5Dwrite(d.get(), nativeType<T>(), H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0)
    return failHdf5("writing " + path);
  attributeOn(d.get(), path, "units", units);
}

void Writer::text(const std::string& path, const std::string& value, const char* media_type) {
  Handle type = stringType();
  Handle d = createDataset(path, type.get(), {});
  if (!ok_) return;
  const char* p = value.c_str();
  if (H5Dwrite(d.get(), type.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, &p) < 0)
    return failHdf5("writing " + path);
  attributeOn(d.get(), path, "units", "");
  attributeOn(d.get(), path, "media_type", media_type);
}

void Writer::strings(const std::string& path, const std::vector<std::string>& values) {
  Handle type = stringType();
  Handle d = createDataset(path, type.get(), {values.size()});
  if (!ok_) return;
  std::vector<const char*> ptrs;
  ptrs.reserve(values.size());
  for (const auto& v : values) ptrs.push_back(v.c_str());
  if (!ptrs.empty() &&
      H5Dwrite(d.get(), type.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, ptrs.data()) < 0)
    return failHdf5("writing " + path);
  attributeOn(d.get(), path, "units", "");
}

template void Writer::dataset(const std::string&, const double*, const std::vector<hsize_t>&,
                              const char*);
template void Writer::dataset(const std::string&, const std::int32_t*, const std::vector<hsize_t>&,
                              const char*);
template void Writer::dataset(const std::string&, const std::int64_t*, const std::vector<hsize_t>&,
                              const char*);
template void Writer::dataset(const std::string&, const std::uint64_t*, const std::vector<hsize_t>&,
                              const char*);
template void Writer::dataset(const std::string&, const std::uint8_t*, const std::vector<hsize_t>&,
                              const char*);

// ---------------------------------------------------------------- Reader

void Reader::failHdf5(const std::string& what) {
  failHdf5(what, lastCause());
}

void Reader::failHdf5(const std::string& what, const Cause& cause) {
  if (!ok_) return;
  if (cause.errno_value != 0)
    fail(ioError(cause.errno_value, "reading", display_path_));
  else
    fail(collide::fail("cannot read " + display_path_ + ": HDF5 failed " + what + " (" +
                       cause.text + "); the file may be corrupt"));
}

void Reader::fail(Error error) {
  if (!ok_) return;
  ok_ = false;
  error_ = std::move(error);
}

bool Reader::exists(const std::string& path) {
  if (!ok_) return false;
  // H5Lexists fails (rather than answering no) when a parent is missing, so
  // walk down one component at a time.
  std::string prefix;
  std::size_t start = 1;
  while (start <= path.size()) {
    const std::size_t end = std::min(path.find('/', start), path.size());
    prefix = path.substr(0, end);
    const htri_t found = H5Lexists(file_, prefix.c_str(), H5P_DEFAULT);
    if (found < 0) {
      // Not "absent": the group could not be read (a checksum mismatch in
      // the 1.10 format, a damaged B-tree).
      failHdf5("looking up " + prefix);
      return false;
    }
    if (found == 0) return false;
    start = end + 1;
  }
  return true;
}

bool Reader::attributeExists(const std::string& object, const char* name) {
  const htri_t found = H5Aexists_by_name(file_, object.c_str(), name, H5P_DEFAULT);
  if (found < 0) {
    failHdf5("reading the attributes of " + object);
    return false;
  }
  if (found == 0)
    fail(collide::fail("shot file " + display_path_ + " lacks attribute '" + name + "' of " +
                       object + ": the file is incomplete or was not written by collide"));
  return found > 0;
}

Handle Reader::openDataset(const std::string& path, hid_t dapl) {
  if (!ok_) return {};
  if (!exists(path)) {
    fail(collide::fail("shot file " + display_path_ + " lacks dataset " + path +
                       ": the file is incomplete or was not written by collide"));
    return {};
  }
  Handle d(H5Dopen2(file_, path.c_str(), dapl), H5Dclose);
  if (!d.valid()) failHdf5("opening " + path);
  return d;
}

std::optional<Reader::OneValue> Reader::oneValueAttribute(const std::string& object,
                                                          const char* name, H5T_class_t cls,
                                                          const char* one_what) {
  if (!ok_) return std::nullopt;
  if (!attributeExists(object, name)) return std::nullopt;
  OneValue a;
  a.attr = Handle(H5Aopen_by_name(file_, object.c_str(), name, H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  a.type = Handle(a.attr.valid() ? H5Aget_type(a.attr.get()) : H5I_INVALID_HID, H5Tclose);
  a.space = Handle(a.attr.valid() ? H5Aget_space(a.attr.get()) : H5I_INVALID_HID, H5Sclose);
  if (!a.type.valid() || !a.space.valid()) {
    failHdf5("reading attribute " + std::string(name) + " of " + object);
    return std::nullopt;
  }
  // One value: H5Aread writes every element the attribute holds.
  if (H5Tget_class(a.type.get()) != cls || H5Sget_simple_extent_npoints(a.space.get()) != 1) {
    fail(collide::fail("shot file " + display_path_ + ": attribute '" + name + "' of " + object +
                       " should be " + one_what + "; the file is corrupt or from another program"));
    return std::nullopt;
  }
  return a;
}

std::string Reader::stringAttribute(const std::string& object, const char* name) {
  auto a = oneValueAttribute(object, name, H5T_STRING, "one string");
  if (!a) return {};
  std::vector<std::string> out;
  if (auto cause = readStringsOfType(
          a->type.get(), a->space.get(), 1,
          [&](hid_t mem, void* buf) { return H5Aread(a->attr.get(), mem, buf); }, out)) {
    failHdf5("reading attribute " + std::string(name) + " of " + object, *cause);
    return {};
  }
  return out.front();
}

std::int32_t Reader::intAttribute(const std::string& object, const char* name) {
  auto a = oneValueAttribute(object, name, H5T_INTEGER, "one whole number");
  std::int32_t value = 0;
  if (a && H5Aread(a->attr.get(), H5T_NATIVE_INT32, &value) < 0)
    failHdf5("reading attribute " + std::string(name) + " of " + object);
  return value;
}

bool Reader::heldInFile(hid_t d, const std::string& path, hsize_t count,
                        std::size_t element_bytes) {
  const double declared = static_cast<double>(count) * static_cast<double>(element_bytes);
  Handle dcpl(H5Dget_create_plist(d), H5Pclose);
  const bool filtered = dcpl.valid() && H5Pget_nfilters(dcpl.get()) > 0;
  if (!filtered) {
    // Unfiltered data takes its size in the file: a dataset declaring more
    // than it stores was damaged, or never written (collide writes every
    // dataset whole).
    const double stored = static_cast<double>(H5Dget_storage_size(d));
    if (declared <= stored) return true;
    fail(collide::fail("shot file " + display_path_ + ": dataset " + path + " declares " +
                       std::to_string(count) + " values (" + hw::formatBytes(declared) +
                       ") but the file holds " + hw::formatBytes(stored) +
                       " of data for it; the file is corrupt or incomplete"));
    return false;
  }
  // Compressed data can expand, but never past the memory there is.
  const auto avail = hw::availableMemoryBytes();
  if (!avail || declared <= 0.5 * static_cast<double>(*avail)) return true;
  fail(collide::fail("shot file " + display_path_ + ": dataset " + path + " declares " +
                     std::to_string(count) + " values (" + hw::formatBytes(declared) +
                     "), more than half the " + hw::formatBytes(static_cast<double>(*avail)) +
                     " of memory free here; the file is corrupt"));
  return false;
}

bool Reader::referencesSound(hid_t d, hid_t type, const std::string& path, std::size_t count) {
  if (H5Tis_variable_str(type) <= 0) return true;
  // Stored in the object header (compact) or in chunks: left to the library.
  const haddr_t offset = H5Dget_offset(d);
  if (offset == HADDR_UNDEF) return true;
  const auto damage = stringReferenceDamage(file_, offset, count);
  if (!damage) return true;
  fail(collide::fail("shot file " + display_path_ + ": dataset " + path +
                     " is corrupt: " + *damage));
  return false;
}

template <class T>
std::vector<T> Reader::dataset(const std::string& path, const std::vector<hsize_t>& expected,
                               std::vector<hsize_t>* dims_out) {
  Handle d = openDataset(path);
  if (!ok_) return {};
  Handle space(H5Dget_space(d.get()), H5Sclose);
  Handle type(H5Dget_type(d.get()), H5Tclose);
  if (!space.valid() || !type.valid()) {
    failHdf5("inspecting " + path);
    return {};
  }
  const int rank = H5Sget_simple_extent_ndims(space.get());
  std::vector<hsize_t> dims(rank > 0 ? rank : 0);
  if (rank > 0) H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr);
  bool shape_ok = dims.size() == expected.size();
  for (std::size_t i = 0; shape_ok && i < dims.size(); ++i)
    shape_ok = expected[i] == kAnySize || expected[i] == dims[i];
  const H5T_class_t cls = H5Tget_class(type.get());
  if (!shape_ok || (cls != H5T_INTEGER && cls != H5T_FLOAT)) {
    fail(collide::fail(
        "shot file " + display_path_ + ": dataset " + path + " should hold " +
        (expected.empty() ? std::string("one number") : "numbers of shape " + shapeText(expected)) +
        " but holds " + (cls == H5T_INTEGER || cls == H5T_FLOAT ? "numbers" : "other data") +
        " of shape " + shapeText(dims) + "; the file is corrupt or was not written by collide"));
    return {};
  }
  if (!heldInFile(d.get(), path, elementCount(dims), H5Tget_size(type.get()))) return {};
  std::vector<T> values(elementCount(dims));
  if (!values.empty() &&
      H5Dread(d.get(), nativeType<T>(), H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()) < 0) {
    failHdf5("reading " + path);
    return {};
  }
  if (dims_out) *dims_out = dims;
  return values;
}

std::vector<std::string> Reader::readStrings(const std::string& path, int expected_rank) {
  Handle d = openDataset(path);
  if (!ok_) return {};
  Handle space(H5Dget_space(d.get()), H5Sclose);
  Handle type(H5Dget_type(d.get()), H5Tclose);
  if (!space.valid() || !type.valid()) {
    failHdf5("inspecting " + path);
    return {};
  }
  if (H5Tget_class(type.get()) != H5T_STRING ||
      H5Sget_simple_extent_ndims(space.get()) != expected_rank) {
    fail(collide::fail("shot file " + display_path_ + ": dataset " + path + " should hold " +
                       (expected_rank == 0 ? "one string" : "a list of strings") +
                       "; the file is corrupt or was not written by collide"));
    return {};
  }
  std::vector<std::string> out;
  const auto count = static_cast<std::size_t>(H5Sget_simple_extent_npoints(space.get()));
  // A fixed-length string takes its size in the file; a variable-length one
  // at least a byte (its reference there).
  const std::size_t string_bytes =
      H5Tis_variable_str(type.get()) > 0 ? 1 : std::max<std::size_t>(1, H5Tget_size(type.get()));
  if (!heldInFile(d.get(), path, count, string_bytes)) return {};
  if (!referencesSound(d.get(), type.get(), path, count)) return {};
  if (auto cause = readStringsOfType(
          type.get(), space.get(), count,
          [&](hid_t mem, void* buf) {
            return H5Dread(d.get(), mem, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf);
          },
          out)) {
    failHdf5("reading " + path, *cause);
    return {};
  }
  return out;
}

std::string Reader::text(const std::string& path) {
  std::vector<std::string> v = readStrings(path, 0);
  return v.empty() ? std::string() : v.front();
}

std::vector<std::string> Reader::strings(const std::string& path) {
  return readStrings(path, 1);
}

template std::vector<double> Reader::dataset(const std::string&, const std::vector<hsize_t>&,
                                             std::vector<hsize_t>*);
template std::vector<std::int32_t> Reader::dataset(const std::string&, const std::vector<hsize_t>&,
                                                   std::vector<hsize_t>*);
template std::vector<std::int64_t> Reader::dataset(const std::string&, const std::vector<hsize_t>&,
                                                   std::vector<hsize_t>*);
template std::vector<std::uint64_t> Reader::dataset(const std::string&, const std::vector<hsize_t>&,
                                                    std::vector<hsize_t>*);
template std::vector<std::uint8_t> Reader::dataset(const std::string&, const std::vector<hsize_t>&,
                                                   std::vector<hsize_t>*);

// ---------------------------------------------------------------- VlenJournal

JournalScope::JournalScope(VlenJournal& journal) : previous_(active_journal) {
  active_journal = &journal;
}

JournalScope::~JournalScope() {
  active_journal = previous_;
}

namespace {

constexpr char kJournalMagic[8] = {'C', 'O', 'L', 'V', 'J', 'N', 'L', '1'};

template <class T>
void append(std::string& out, const T& value) {
  out.append(reinterpret_cast<const char*>(&value), sizeof value);
}

void appendText(std::string& out, const std::string& text) {
  append(out, static_cast<std::uint64_t>(text.size()));
  out += text;
}

bool readText(int fd, std::uint64_t left, std::string& text) {
  std::uint64_t size = 0;
  if (!readAllFromFd(fd, &size, sizeof size) || size > left) return false;
  text.resize(size);
  return readAllFromFd(fd, text.data(), size);
}

}  // namespace

bool VlenJournal::save(int fd) const {
  std::string out(kJournalMagic, sizeof kJournalMagic);
  append(out, static_cast<std::uint64_t>(reads.size()));
  for (const Read& r : reads) {
    append(out, static_cast<std::uint8_t>(r.failed ? 1 : 0));
    appendText(out, r.cause);
    append(out, static_cast<std::uint64_t>(r.strings.size()));
    for (const auto& s : r.strings) appendText(out, s);
  }
  return ::lseek(fd, 0, SEEK_SET) == 0 && writeAllToFd(fd, out) == 0;
}

std::optional<VlenJournal> VlenJournal::load(int fd) {
  struct stat st {};
  if (::fstat(fd, &st) != 0 || ::lseek(fd, 0, SEEK_SET) != 0) return std::nullopt;
  // No size read from the journal may exceed what the journal holds.
  const auto left = static_cast<std::uint64_t>(st.st_size);
  char magic[sizeof kJournalMagic] = {};
  std::uint64_t n = 0;
  if (!readAllFromFd(fd, magic, sizeof magic) ||
      std::memcmp(magic, kJournalMagic, sizeof magic) != 0 || !readAllFromFd(fd, &n, sizeof n) ||
      n > left)
    return std::nullopt;
  VlenJournal journal;
  journal.mode = Mode::Replay;
  journal.reads.resize(n);
  for (Read& r : journal.reads) {
    std::uint8_t failed = 0;
    std::uint64_t count = 0;
    if (!readAllFromFd(fd, &failed, 1) || !readText(fd, left, r.cause) ||
        !readAllFromFd(fd, &count, sizeof count) || count > left)
      return std::nullopt;
    r.failed = failed != 0;
    r.strings.resize(count);
    for (auto& s : r.strings)
      if (!readText(fd, left, s)) return std::nullopt;
  }
  return journal;
}

}  // namespace collide::app::h5
