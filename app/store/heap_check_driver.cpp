#include "app/store/heap_check_driver.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <map>
#include <new>
#include <vector>

namespace collide::app::h5 {

namespace {

// The collection's layout (HDF5 file format spec, "Global Heap"): "GCOL",
// version 1, 3 reserved bytes, the collection's size in bytes (a length);
// then objects, each a 2-byte index, 2-byte reference count, 4 reserved bytes,
// its size (a length) and its data padded to 8 bytes. Index 0 is the free
// space, whose size covers its own header.
constexpr char kCollectionStart[8] = {'G', 'C', 'O', 'L', 1, 0, 0, 0};
constexpr char kSuperblockSignature[8] = {'\x89', 'H', 'D', 'F', '\r', '\n', '\x1a', '\n'};
/// The size libhdf5 gives every new collection at least (H5HG_MINSIZE), and
/// reads first when it loads one.
constexpr std::size_t kCollectionMinimum = 4096;
/// Collections larger than this are left to the library unchecked (a
/// variable-length string of more than 1 GiB; no shot file holds one).
constexpr std::uint64_t kLargestChecked = std::uint64_t{1} << 30;

std::uint64_t decodeLength(const unsigned char* p, unsigned n) {
  std::uint64_t v = 0;
  for (unsigned i = n; i-- > 0;) v = (v << 8) | p[i];
  return v;
}

/// One open file: the library's public part first, as every driver's.
struct File {
  H5FD_t pub;
  int fd = -1;
  haddr_t eoa = 0;
  haddr_t eof = 0;
  dev_t device = 0;
  ino_t inode = 0;
  unsigned length_size = 0;                    // from the superblock; 0 until it is read
  haddr_t checked_begin = 0, checked_end = 0;  // the last collection checked
};

void pushError(const std::string& text) {
  H5Epush2(H5E_DEFAULT, __FILE__, "collide heap check", __LINE__, H5E_ERR_CLS, H5E_VFL,
           H5E_READERROR, "%s", text.c_str());
}

H5FD_t* openFile(const char* name, unsigned flags, hid_t, haddr_t) {
  if (flags & (H5F_ACC_RDWR | H5F_ACC_TRUNC | H5F_ACC_CREAT)) {
    pushError("the heap-checking driver only reads");
    return nullptr;
  }
  const int fd = ::open(name, O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    pushError(std::string("unable to open file: ") + std::strerror(errno) +
              ", errno = " + std::to_string(errno));
    return nullptr;
  }
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    pushError(std::string("unable to stat file: ") + std::strerror(errno));
    ::close(fd);
    return nullptr;
  }
  auto* file = new (std::nothrow) File{};
  if (!file) {
    ::close(fd);
    pushError("out of memory");
    return nullptr;
  }
  file->fd = fd;
  file->eof = static_cast<haddr_t>(st.st_size);
  file->device = st.st_dev;
  file->inode = st.st_ino;
  return &file->pub;
}

File* of(H5FD_t* f) {
  return reinterpret_cast<File*>(f);
}
const File* of(const H5FD_t* f) {
  return reinterpret_cast<const File*>(f);
}

herr_t closeFile(H5FD_t* f) {
  File* file = of(f);
  const int status = ::close(file->fd);
  delete file;
  return status == 0 ? 0 : -1;
}

int compareFiles(const H5FD_t* a, const H5FD_t* b) {
  const File *fa = of(a), *fb = of(b);
  if (fa->device != fb->device) return fa->device < fb->device ? -1 : 1;
  if (fa->inode != fb->inode) return fa->inode < fb->inode ? -1 : 1;
  return 0;
}

herr_t query(const H5FD_t*, unsigned long* flags) {
  // No metadata accumulation: every metadata read (the superblock's among
  // them) arrives here as the library asked for it.
  if (flags) *flags = H5FD_FEAT_DATA_SIEVE;
  return 0;
}

haddr_t getEoa(const H5FD_t* f, H5FD_mem_t) {
  return of(f)->eoa;
}
herr_t setEoa(H5FD_t* f, H5FD_mem_t, haddr_t addr) {
  of(f)->eoa = addr;
  return 0;
}
haddr_t getEof(const H5FD_t* f, H5FD_mem_t) {
  return of(f)->eof;
}
herr_t getHandle(H5FD_t* f, hid_t, void** handle) {
  *handle = &of(f)->fd;
  return 0;
}

/// Reads `size` bytes at `addr`; past the end of the file reads zeros (as the
/// library's POSIX driver does).
bool readAt(const File& file, haddr_t addr, std::size_t size, unsigned char* out) {
  while (size > 0) {
    const ssize_t n = ::pread(file.fd, out, size, static_cast<off_t>(addr));
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      pushError(std::string("file read failed: ") + std::strerror(errno) +
                ", errno = " + std::to_string(errno));
      return false;
    }
    if (n == 0) {
      std::memset(out, 0, size);
      return true;
    }
    addr += static_cast<haddr_t>(n);
    out += n;
    size -= static_cast<std::size_t>(n);
  }
  return true;
}

void noteSuperblock(File& file, const unsigned char* bytes, std::size_t size) {
  if (size < 15 || std::memcmp(bytes, kSuperblockSignature, 8) != 0) return;
  const unsigned version = bytes[8];
  const unsigned length_size = version >= 2 ? bytes[10] : bytes[14];
  if (length_size >= 2 && length_size <= 8) file.length_size = length_size;
}

/// Checks the collection a global-heap read at `addr` starts; false (with the
/// library's error stack telling why) if libhdf5 must not parse it.
bool checkCollection(File& file, haddr_t addr, const unsigned char* bytes, std::size_t size) {
  const unsigned L = file.length_size;
  if (L == 0 || size < 8 + L || std::memcmp(bytes, kCollectionStart, 8) != 0) return true;
  // The library loads a collection by first reading its minimum size (4096
  // bytes, less if the file ends sooner), then the rest if it is larger: a
  // raw-data read of another size that happens to start with the same 8
  // bytes (a frame's first pixels) is not one.
  if (size != kCollectionMinimum && addr + size != file.eoa) return true;
  // The rest of a collection the library reads in two parts.
  if (addr > file.checked_begin && addr < file.checked_end) return true;
  const std::uint64_t declared = decodeLength(bytes + 8, L);
  const std::string where = "corrupt global heap: the collection at byte " + std::to_string(addr);
  if (declared > file.eof || addr > file.eof - declared) {
    pushError(where + " declares " + std::to_string(declared) +
              " bytes, past the end of the file (" + std::to_string(file.eof) + " bytes)");
    return false;
  }
  if (declared > kLargestChecked) return true;
  std::vector<unsigned char> whole;
  const unsigned char* image = bytes;
  if (declared > size) {
    whole.resize(declared);
    if (!readAt(file, addr, declared, whole.data())) return false;
    image = whole.data();
  }
  if (auto damage = globalHeapDamage(image, declared, L)) {
    pushError(where + ": " + *damage);
    return false;
  }
  file.checked_begin = addr;
  file.checked_end = addr + declared;
  return true;
}

herr_t readFile(H5FD_t* f, H5FD_mem_t type, hid_t, haddr_t addr, std::size_t size, void* buffer) {
  File& file = *of(f);
  if (addr > file.eoa || size > file.eoa - addr) {  // as the POSIX driver refuses it
    pushError("addr overflow, addr = " + std::to_string(addr) + ", size = " + std::to_string(size) +
              ", eoa = " + std::to_string(file.eoa));
    return -1;
  }
  auto* out = static_cast<unsigned char*>(buffer);
  if (!readAt(file, addr, size, out)) return -1;
  if (type == H5FD_MEM_SUPER) noteSuperblock(file, out, size);
  // libhdf5 reads global-heap collections as raw data (H5F__accum_read maps
  // H5FD_MEM_GHEAP to H5FD_MEM_DRAW), so the collection is known by its
  // header: "GCOL", version 1 and three zero bytes.
  if ((type == H5FD_MEM_GHEAP || type == H5FD_MEM_DRAW) && !checkCollection(file, addr, out, size))
    return -1;
  return 0;
}

herr_t writeFile(H5FD_t*, H5FD_mem_t, hid_t, haddr_t, std::size_t, const void*) {
  pushError("the heap-checking driver only reads");
  return -1;
}

const H5FD_class_t kDriver = {
    .name = "collide-heap-check",
    .maxaddr = (haddr_t{1} << 63) - 1,
    .fc_degree = H5F_CLOSE_WEAK,
    .terminate = nullptr,
    .sb_size = nullptr,
    .sb_encode = nullptr,
    .sb_decode = nullptr,
    .fapl_size = 0,
    .fapl_get = nullptr,
    .fapl_copy = nullptr,
    .fapl_free = nullptr,
    .dxpl_size = 0,
    .dxpl_copy = nullptr,
    .dxpl_free = nullptr,
    .open = openFile,
    .close = closeFile,
    .cmp = compareFiles,
    .query = query,
    .get_type_map = nullptr,
    .alloc = nullptr,
    .free = nullptr,
    .get_eoa = getEoa,
    .set_eoa = setEoa,
    .get_eof = getEof,
    .get_handle = getHandle,
    .read = readFile,
    .write = writeFile,
    .flush = nullptr,
    .truncate = nullptr,
    .lock = nullptr,
    .unlock = nullptr,
    .fl_map = H5FD_FLMAP_DICHOTOMY,
};

}  // namespace

namespace {

/// Walks a collection as libhdf5 1.10 does (H5HG__cache_heap_deserialize):
/// what would go wrong, or nothing, with the objects it would know filled into
/// `objects` (index -> size; a later object of the same index replaces an
/// earlier one, as in the library) when that is asked for.
std::optional<std::string> walkCollection(const unsigned char* bytes, std::size_t size,
                                          unsigned length_size,
                                          std::map<unsigned, std::uint64_t>* objects) {
  const std::size_t header = 8 + length_size;  // the collection's, and each object's
  if (size < header) return "shorter than its own header";
  for (std::size_t at = header; at < size;) {
    if (size - at < header) break;  // too small for an object: free space
    const unsigned index = bytes[at] | (bytes[at + 1] << 8);
    const std::uint64_t object = decodeLength(bytes + at + 8, length_size);
    // Named only when something is wrong: the walk runs on every string read.
    const auto which = [&] {
      return "object " + std::to_string(index) + " at byte " + std::to_string(at);
    };
    if (index > 0) {
      if (object > size - at - header)
        return which() + " declares " + std::to_string(object) +
               " bytes, past the collection's end";
      if (objects) (*objects)[index] = object;
      at += header + static_cast<std::size_t>((object + 7) / 8 * 8);
    } else {
      if (object == 0)
        return "its free space (" + which() + ") has size 0, on which the library loops for ever";
      // Far past the end, the library's pointer would wrap round and walk
      // on from anywhere in memory.
      if (object >= (std::uint64_t{1} << 62))
        return "its free space (" + which() + ") declares " + std::to_string(object) + " bytes";
      if (object > size - at) break;  // the walk leaves the collection
      at += static_cast<std::size_t>(object);
    }
  }
  return std::nullopt;
}

/// The objects of the collection at `addr` in `file`, or what is wrong with it.
std::optional<std::string> loadCollection(const File& file, haddr_t addr,
                                          std::map<unsigned, std::uint64_t>& objects) {
  const unsigned L = file.length_size;
  std::vector<unsigned char> head(8 + L);
  if (addr > file.eof || file.eof - addr < head.size() ||
      !readAt(file, addr, head.size(), head.data()))
    return "past the end of the file (" + std::to_string(file.eof) + " bytes)";
  if (std::memcmp(head.data(), kCollectionStart, 8) != 0) return "not a global-heap collection";
  const std::uint64_t declared = decodeLength(head.data() + 8, L);
  if (declared > file.eof - addr)
    return "a collection declaring " + std::to_string(declared) +
           " bytes, past the end of the file";
  if (declared > kLargestChecked)
    return "a collection declaring " + std::to_string(declared) +
           " bytes, larger than any shot file holds";
  std::vector<unsigned char> whole(declared);
  if (!readAt(file, addr, whole.size(), whole.data())) return "unreadable";
  if (auto damage = walkCollection(whole.data(), whole.size(), L, &objects))
    return "a corrupt collection: " + *damage;
  return std::nullopt;
}

}  // namespace

std::optional<std::string> globalHeapDamage(const unsigned char* bytes, std::size_t size,
                                            unsigned length_size) {
  return walkCollection(bytes, size, length_size, nullptr);
}

std::optional<std::string> stringReferenceDamage(hid_t file_id, haddr_t offset, std::size_t count) {
  hid_t fapl = H5Fget_access_plist(file_id);
  if (fapl < 0) return std::nullopt;
  const bool ours = H5Pget_driver(fapl) == heapCheckDriver();
  void* handle = nullptr;
  const bool have_handle = ours && H5Fget_vfd_handle(file_id, fapl, &handle) >= 0 && handle;
  H5Pclose(fapl);
  if (!have_handle) return std::nullopt;  // another driver: leave the file to the library
  // The driver's handle is the address of its file's descriptor (getHandle).
  const File& file =
      *reinterpret_cast<const File*>(reinterpret_cast<const char*>(handle) - offsetof(File, fd));
  hid_t fcpl = H5Fget_create_plist(file_id);
  std::size_t address_size = 0, length_size = 0;
  const bool sized = fcpl >= 0 && H5Pget_sizes(fcpl, &address_size, &length_size) >= 0;
  if (fcpl >= 0) H5Pclose(fcpl);
  if (!sized || address_size < 2 || address_size > 8 || file.length_size == 0) return std::nullopt;
  // Each reference (HDF5 file format spec, "Variable-length data"): the
  // string's length (4 bytes), the collection's address, the object's index
  // (4 bytes).
  const std::size_t ref_size = 8 + address_size;
  if (count > (file.eof - std::min<haddr_t>(offset, file.eof)) / ref_size)
    return "its " + std::to_string(count) + " string references run past the end of the file";
  std::vector<unsigned char> refs(count * ref_size);
  if (!readAt(file, offset, refs.size(), refs.data()))
    return "its string references are unreadable";
  std::map<haddr_t, std::map<unsigned, std::uint64_t>> collections;
  for (std::size_t i = 0; i < count; ++i) {
    const unsigned char* r = refs.data() + i * ref_size;
    const std::uint64_t length = decodeLength(r, 4);
    const haddr_t addr = decodeLength(r + 4, static_cast<unsigned>(address_size));
    const unsigned index = static_cast<unsigned>(decodeLength(r + 4 + address_size, 4));
    if (addr == 0) continue;  // a null string: nothing is read
    const auto which = [&] {
      return "string " + std::to_string(i) + " refers to object " + std::to_string(index) +
             " of the global heap at byte " + std::to_string(addr);
    };
    auto found = collections.find(addr);
    if (found == collections.end()) {
      std::map<unsigned, std::uint64_t> objects;
      if (auto damage = loadCollection(file, addr, objects)) return which() + ", " + *damage;
      found = collections.emplace(addr, std::move(objects)).first;
    }
    // libhdf5 1.10 reads the object without checking that it exists
    // (H5HG_read), and copies its whole size into a buffer of the string's.
    const auto object = found->second.find(index);
    if (object == found->second.end()) return which() + ", which has no such object";
    if (object->second != length)
      return which() + ", which holds " + std::to_string(object->second) + " bytes, not the " +
             std::to_string(length) + " the string declares";
  }
  return std::nullopt;
}

hid_t heapCheckDriver() {
  static const hid_t id = H5FDregister(&kDriver);
  return id;
}

}  // namespace collide::app::h5
