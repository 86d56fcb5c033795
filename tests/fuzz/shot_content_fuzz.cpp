// Fuzz target: the shot file reader on well-formed HDF5 with unexpected
// content. shot_file_fuzz flips bytes of a shot file: nearly every flip lands
// in metadata the 1.10 format checksums and is refused by the library before
// our code sees it, and each input is read in a forked child (the contained
// read), which holds it to tens of inputs a second. Here the input is a list
// of edits made through the HDF5 library to a valid shot file: objects
// removed; datasets replaced by others of another rank, shape (declared up to
// 2^40 elements, with no data written), type or content; attributes rewritten
// with other values and types; text replaced by arbitrary bytes. The file is
// always one libhdf5 wrote, so it is read in this process (not contained) and
// every path of our reader after the library runs, thousands of times a
// second. Every input gives a shot or a one-line error naming the file; no
// dimension in the file sizes an allocation unchecked.
#include <fuzzer/FuzzedDataProvider.h>
#include <hdf5.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "app/store/shot_file.hpp"
#include "tests/app/shot_fixtures.hpp"
#include "tests/fuzz/seeds.hpp"

namespace {

/// A seed shot file and what is in it.
struct Seed {
  std::string bytes;
  std::vector<std::string> objects;                             // groups and datasets
  std::vector<std::pair<std::string, std::string>> attributes;  // object, name
};

std::vector<Seed>& seeds() {
  static std::vector<Seed> s;
  return s;
}

herr_t collectObject(hid_t, const char* name, const H5O_info_t*, void* out) {
  if (std::string(name) != ".") static_cast<Seed*>(out)->objects.push_back(std::string("/") + name);
  return 0;
}

herr_t collectAttribute(hid_t, const char* name, const H5A_info_t*, void* out) {
  auto* p = static_cast<std::pair<Seed*, std::string>*>(out);
  p->first->attributes.emplace_back(p->second, name);
  return 0;
}

Seed describe(const std::string& path) {
  Seed s;
  s.bytes = collide::fuzz::readFile(path);
  const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  H5Ovisit2(f, H5_INDEX_NAME, H5_ITER_NATIVE, &collectObject, &s, H5O_INFO_BASIC);
  std::vector<std::string> all = s.objects;
  all.push_back("/");
  for (const std::string& o : all) {
    std::pair<Seed*, std::string> p{&s, o};
    H5Aiterate_by_name(f, o.c_str(), H5_INDEX_NAME, H5_ITER_NATIVE, nullptr, &collectAttribute, &p,
                       H5P_DEFAULT);
  }
  H5Fclose(f);
  return s;
}

/// A datatype the fuzzer picks: integers and floats of every size, strings
/// of fixed and variable length.
hid_t pickType(FuzzedDataProvider& in) {
  static const hid_t kNumbers[] = {H5T_STD_I8LE,   H5T_STD_U8LE,  H5T_STD_I16LE, H5T_STD_U16LE,
                                   H5T_STD_I32LE,  H5T_STD_U32LE, H5T_STD_I64LE, H5T_STD_U64LE,
                                   H5T_IEEE_F32LE, H5T_IEEE_F64LE};
  const int k = in.ConsumeIntegralInRange<int>(0, std::size(kNumbers) + 1);
  if (k < static_cast<int>(std::size(kNumbers))) return H5Tcopy(kNumbers[k]);
  const hid_t t = H5Tcopy(H5T_C_S1);
  H5Tset_size(t, k == std::size(kNumbers) ? H5T_VARIABLE : in.ConsumeIntegralInRange<int>(1, 64));
  return t;
}

/// Fills `bytes` of data for `count` elements of `type` (variable-length
/// strings get pointers to strings the fuzzer chose).
void fillData(FuzzedDataProvider& in, hid_t type, std::size_t count, std::vector<char>& bytes,
              std::vector<std::string>& strings, std::vector<const char*>& pointers) {
  if (H5Tis_variable_str(type) > 0) {
    for (std::size_t i = 0; i < count; ++i) strings.push_back(in.ConsumeRandomLengthString(64));
    for (const std::string& s : strings) pointers.push_back(s.c_str());
    return;
  }
  bytes.resize(count * H5Tget_size(type));
  const std::vector<std::uint8_t> given = in.ConsumeBytes<std::uint8_t>(bytes.size());
  std::copy(given.begin(), given.end(), bytes.begin());
}

/// Dimensions: mostly small, sometimes huge (declared, never written).
std::vector<hsize_t> pickDims(FuzzedDataProvider& in, bool& huge) {
  const int rank = in.ConsumeIntegralInRange<int>(0, 4);
  std::vector<hsize_t> dims(rank);
  huge = false;
  for (hsize_t& d : dims) {
    if (in.ConsumeProbability<float>() < 0.1f) {
      d = hsize_t{1} << in.ConsumeIntegralInRange<int>(16, 40);
      huge = true;
    } else {
      d = in.ConsumeIntegralInRange<hsize_t>(0, 8);
    }
  }
  return dims;
}

/// Replaces dataset (or group) `path` by a dataset the fuzzer shapes.
void replaceDataset(hid_t f, const std::string& path, FuzzedDataProvider& in) {
  H5Ldelete(f, path.c_str(), H5P_DEFAULT);
  const hid_t type = pickType(in);
  bool huge = false;
  const std::vector<hsize_t> dims = pickDims(in, huge);
  const hid_t space = dims.empty()
                          ? H5Screate(H5S_SCALAR)
                          : H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr);
  const hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
  if (huge) {
    // Declared but never written: chunks of one element, none allocated.
    std::vector<hsize_t> chunk(dims.size(), 1);
    H5Pset_chunk(dcpl, static_cast<int>(chunk.size()), chunk.data());
  }
  const hid_t lcpl = H5Pcreate(H5P_LINK_CREATE);
  H5Pset_create_intermediate_group(lcpl, 1);
  const hid_t d = H5Dcreate2(f, path.c_str(), type, space, lcpl, dcpl, H5P_DEFAULT);
  if (d >= 0 && !huge) {
    hsize_t count = 1;
    for (hsize_t x : dims) count *= x;
    std::vector<char> bytes;
    std::vector<std::string> strings;
    std::vector<const char*> pointers;
    fillData(in, type, count, bytes, strings, pointers);
    const void* data = H5Tis_variable_str(type) > 0 ? static_cast<const void*>(pointers.data())
                                                    : static_cast<const void*>(bytes.data());
    if (count > 0) H5Dwrite(d, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data);
  }
  if (d >= 0) H5Dclose(d);
  H5Pclose(lcpl);
  H5Pclose(dcpl);
  H5Sclose(space);
  H5Tclose(type);
}

/// Rewrites attribute `name` of `object` with a value the fuzzer chose.
void replaceAttribute(hid_t f, const std::string& object, const std::string& name,
                      FuzzedDataProvider& in) {
  H5Adelete_by_name(f, object.c_str(), name.c_str(), H5P_DEFAULT);
  const hid_t type = pickType(in);
  const int n = in.ConsumeIntegralInRange<int>(0, 3);  // 0: scalar
  const hsize_t dim = static_cast<hsize_t>(n);
  const hid_t space = n == 0 ? H5Screate(H5S_SCALAR) : H5Screate_simple(1, &dim, nullptr);
  const hid_t a = H5Acreate_by_name(f, object.c_str(), name.c_str(), type, space, H5P_DEFAULT,
                                    H5P_DEFAULT, H5P_DEFAULT);
  if (a >= 0) {
    std::vector<char> bytes;
    std::vector<std::string> strings;
    std::vector<const char*> pointers;
    fillData(in, type, n == 0 ? 1 : n, bytes, strings, pointers);
    const void* data = H5Tis_variable_str(type) > 0 ? static_cast<const void*>(pointers.data())
                                                    : static_cast<const void*>(bytes.data());
    H5Awrite(a, type, data);
    H5Aclose(a);
  }
  H5Sclose(space);
  H5Tclose(type);
}

/// One edit of the file, chosen by the input.
void edit(hid_t f, const Seed& seed, FuzzedDataProvider& in) {
  switch (in.ConsumeIntegralInRange<int>(0, 3)) {
    case 0: {  // an object removed
      const auto& o =
          seed.objects[in.ConsumeIntegralInRange<std::size_t>(0, seed.objects.size() - 1)];
      H5Ldelete(f, o.c_str(), H5P_DEFAULT);
      break;
    }
    case 1: {  // a dataset (or group) replaced
      const auto& o =
          seed.objects[in.ConsumeIntegralInRange<std::size_t>(0, seed.objects.size() - 1)];
      replaceDataset(f, o, in);
      break;
    }
    case 2: {  // an attribute rewritten
      const auto& [o, name] =
          seed.attributes[in.ConsumeIntegralInRange<std::size_t>(0, seed.attributes.size() - 1)];
      replaceAttribute(f, o, name, in);
      break;
    }
    default: {  // an attribute removed
      const auto& [o, name] =
          seed.attributes[in.ConsumeIntegralInRange<std::size_t>(0, seed.attributes.size() - 1)];
      H5Adelete_by_name(f, o.c_str(), name.c_str(), H5P_DEFAULT);
      break;
    }
  }
}

}  // namespace

// Seeds: small valid shot files (8 and 16-bit, with truth and results),
// described once; the corpus holds edit lists, which start empty.
extern "C" int LLVMFuzzerInitialize(int*, char***) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);  // the edits fail often; say nothing
  const std::string dir = "/tmp/collide-shot-content-seeds-" + std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  for (const std::string& path : collide::fuzz::writeSmallShots(dir))
    seeds().push_back(describe(path));
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
  for (const Seed& seed : seeds())
    if (seed.objects.empty() || seed.attributes.empty()) __builtin_trap();  // unreadable seed
  if (seeds().empty()) __builtin_trap();  // the writer itself is broken
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string path = collide::fuzz::scratchPath("shot-content-fuzz", ".h5");
  FuzzedDataProvider in(data, size);
  const Seed& seed = seeds()[in.ConsumeIntegralInRange<std::size_t>(0, seeds().size() - 1)];
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(seed.bytes.data(), static_cast<std::streamsize>(seed.bytes.size()));
  }
  const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  if (f < 0) __builtin_trap();  // the seed did not open: nothing here is tested
  const int edits = in.ConsumeIntegralInRange<int>(1, 6);
  for (int i = 0; i < edits && in.remaining_bytes() > 0; ++i) edit(f, seed, in);
  H5Fclose(f);
  // In this process: the library reads a file it wrote (see the top).
  auto shot = collide::app::readShot(path, {.frames = true, .contained = false});
  if (!shot && shot.error().message.find(path) == std::string::npos) __builtin_trap();
  return 0;
}
