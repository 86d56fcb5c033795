#pragma once
// A read-only HDF5 file driver that checks every global-heap collection (where
// variable-length strings live) before libhdf5 parses it. libhdf5 1.10 trusts
// the collection: a free-space object of size 0 makes it loop for ever
// (H5HG__cache_heap_deserialize never moves on), and an object whose size runs
// past the collection makes it copy past its buffer (H5HG_read). Both were
// found by shot_file_fuzz; with this driver such a file is refused at once with
// an error naming the byte, instead of costing the contained read's time limit
// or a crash of its helper. Reading is otherwise the library's own POSIX
// driver's (pread on a file descriptor).

#include <hdf5.h>

#include <cstddef>
#include <optional>
#include <string>

namespace collide::app::h5 {

/// The driver's id, registered on first use; a negative id if the library
/// refused it (then open files with the default driver). For H5Pset_driver on
/// a file-access list that opens files read-only.
hid_t heapCheckDriver();

/// What is wrong with the global-heap collection whose whole image (as long
/// as its header declares) is `bytes`, for libhdf5 1.10 to parse it; nothing
/// if it parses safely. `length_size` is the file's size of lengths (from its
/// superblock), 2 to 8 bytes.
std::optional<std::string> globalHeapDamage(const unsigned char* bytes, std::size_t size,
                                            unsigned length_size);

/// What is wrong with the `count` variable-length string references a dataset
/// stores contiguously at byte `offset` of `file` (opened with this driver),
/// for libhdf5 1.10 to follow them; nothing if it can. Each names an object of
/// a global-heap collection, which libhdf5 reads without checking that it
/// exists or has the string's length (H5HG_read: a damaged index reads a
/// pointer from past the collection's object table). Nothing is said of a
/// file opened with another driver.
std::optional<std::string> stringReferenceDamage(hid_t file, haddr_t offset, std::size_t count);

}  // namespace collide::app::h5
