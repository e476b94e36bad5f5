#include "store/hdf5.h"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <string>

namespace kgd::hdf5 {
namespace {

// The last failure of this thread's HDF5 calls. One with a system error (errno) is kept over later
// ones without (the closes that follow a failed write fail too, for HDF5's own reasons).
thread_local std::string last_error;
thread_local int last_errno = 0;

herr_t RecordEntry(unsigned n, const H5E_error2_t* e, void* data) {
  auto* found = static_cast<std::pair<std::string, int>*>(data);
  if (!e->desc) return 0;
  const std::string desc = e->desc;
  // The POSIX drivers write "..., errno = 28, error message = 'No space left on device', ...".
  if (const size_t at = desc.find("errno = "); at != std::string::npos && found->second == 0) {
    const int number = std::atoi(desc.c_str() + at + 8);
    if (number > 0) {
      const char* name = strerrorname_np(number);
      found->first = std::string(std::strerror(number)) + " (" + (name ? name : "errno " + std::to_string(number)) + ")";
      found->second = number;
    }
  }
  if (found->first.empty() && n == 0) found->first = desc;  // the innermost entry: where it failed
  return 0;
}

herr_t RecordFailure(hid_t stack, void*) {
  std::pair<std::string, int> found;
  H5Ewalk2(stack, H5E_WALK_UPWARD, RecordEntry, &found);
  if (found.first.empty()) return 0;
  if (found.second != 0 || last_errno == 0) {
    last_error = found.first;
    last_errno = found.second;
  }
  return 0;
}

}  // namespace

void SilenceHdf5() {
  // No clean-up at exit: HDF5 1.10 closes files still open there, and one whose close failed before (a
  // full disk) crashes it. Every writer closes its file itself.
  static bool no_atexit = [] { return H5dont_atexit() >= 0; }();
  (void)no_atexit;
  thread_local bool done = [] {
    H5Eset_auto2(H5E_DEFAULT, RecordFailure, nullptr);
    return true;
  }();
  (void)done;
}

std::string LastHdf5Error() {
  std::string e = last_error.empty() ? "an HDF5 error" : last_error;
  last_error.clear();
  last_errno = 0;
  return e;
}

int LastHdf5Errno() { return last_errno; }

void ClearHdf5Error() {
  last_error.clear();
  last_errno = 0;
}

bool WriteStringAttribute(hid_t obj, const char* name, const std::string& value) {
  Id type(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(type, value.empty() ? 1 : value.size());
  H5Tset_strpad(type, H5T_STR_NULLPAD);
  H5Tset_cset(type, H5T_CSET_UTF8);
  Id space(H5Screate(H5S_SCALAR), H5Sclose);
  Id attr(H5Acreate2(obj, name, type, space, H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  if (!attr.ok()) return false;
  const std::string padded = value.empty() ? std::string(1, '\0') : value;
  return H5Awrite(attr, type, padded.data()) >= 0 && attr.Close();
}

bool ReadStringAttribute(hid_t obj, const char* name, std::string* value) {
  Id attr(H5Aopen(obj, name, H5P_DEFAULT), H5Aclose);
  if (!attr.ok()) return false;
  Id type(H5Aget_type(attr), H5Tclose);
  if (H5Tget_class(type) != H5T_STRING || H5Tis_variable_str(type) > 0) return false;
  const size_t n = H5Tget_size(type);
  std::string buf(n + 1, '\0');
  // Read in the stored type (fixed length): no conversion between character sets or paddings.
  if (H5Aread(attr, type, buf.data()) < 0) return false;
  buf.resize(std::strlen(buf.c_str()));
  *value = buf;
  return true;
}

bool WriteIntAttribute(hid_t obj, const char* name, int value) {
  Id space(H5Screate(H5S_SCALAR), H5Sclose);
  Id attr(H5Acreate2(obj, name, H5T_STD_I32LE, space, H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  return attr.ok() && H5Awrite(attr, H5T_NATIVE_INT, &value) >= 0 && attr.Close();
}

bool ReadIntAttribute(hid_t obj, const char* name, int* value) {
  Id attr(H5Aopen(obj, name, H5P_DEFAULT), H5Aclose);
  return attr.ok() && H5Aread(attr, H5T_NATIVE_INT, value) >= 0;
}

// A fixed-size dataset written at once (row-major data).
bool WriteFixed(hid_t group, const char* name, hid_t file_type, hid_t mem_type, const std::vector<hsize_t>& dims, const void* data) {
  Id space(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr), H5Sclose);
  bool empty = false;
  for (hsize_t d : dims) empty |= d == 0;
  // One chunk, for its checksum (see CreateGrowing); an empty dataset cannot be chunked.
  Id plist(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
  if (!empty) {
    H5Pset_chunk(plist, static_cast<int>(dims.size()), dims.data());
    H5Pset_fletcher32(plist);
  }
  Id set(H5Dcreate2(group, name, file_type, space, H5P_DEFAULT, plist, H5P_DEFAULT), H5Dclose);
  if (!set.ok()) return false;
  return (empty || H5Dwrite(set, mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) >= 0) && set.Close();
}

// The current extent of an open dataset.
std::vector<hsize_t> Dims(hid_t set) {
  Id space(H5Dget_space(set), H5Sclose);
  const int rank = H5Sget_simple_extent_ndims(space);
  std::vector<hsize_t> dims(rank > 0 ? rank : 0);
  if (rank > 0) H5Sget_simple_extent_dims(space, dims.data(), nullptr);
  return dims;
}

// The shape of a dataset, or empty if it does not exist.
std::vector<hsize_t> Shape(hid_t group, const char* name) {
  if (H5Lexists(group, name, H5P_DEFAULT) <= 0) return {};
  Id set(H5Dopen2(group, name, H5P_DEFAULT), H5Dclose);
  return set.ok() ? Dims(set) : std::vector<hsize_t>{};
}

bool ReadAll(hid_t group, const char* name, hid_t mem_type, void* data) {
  Id set(H5Dopen2(group, name, H5P_DEFAULT), H5Dclose);
  return set.ok() && H5Dread(set, mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) >= 0;
}

// An extendible dataset of rows of shape `row`, one chunk per row (per 64 rows for scalars, so that a
// history reads in a few chunks).
bool CreateGrowing(hid_t group, const char* name, hid_t file_type, const std::vector<hsize_t>& row, Storage storage) {
  std::vector<hsize_t> dims{0}, max{H5S_UNLIMITED}, chunk{row.empty() ? hsize_t{64} : hsize_t{1}};
  for (hsize_t r : row) {
    dims.push_back(r);
    max.push_back(r);
    chunk.push_back(std::max<hsize_t>(r, 1));
  }
  Id space(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), max.data()), H5Sclose);
  Id plist(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
  H5Pset_chunk(plist, static_cast<int>(chunk.size()), chunk.data());
  if (storage == Storage::kDeflated) {
    H5Pset_shuffle(plist);
    H5Pset_deflate(plist, 4);
  }
  // HDF5 checksums its metadata but not raw data: without this a flipped byte in a chunk of positions
  // read back silently as another number. With it the chunk fails to read, and the iteration is
  // treated as damaged (Reopen rebuilds the file without it).
  H5Pset_fletcher32(plist);
  Id set(H5Dcreate2(group, name, file_type, space, H5P_DEFAULT, plist, H5P_DEFAULT), H5Dclose);
  return set.ok() && set.Close();
}

namespace {
// Selects rows [first, first + rows) of `file_space` and returns the matching memory space.
Id SelectRows(hid_t file_space, hsize_t first, hsize_t rows = 1) {
  const int rank = H5Sget_simple_extent_ndims(file_space);
  std::vector<hsize_t> start(rank, 0), count(rank);
  H5Sget_simple_extent_dims(file_space, count.data(), nullptr);
  start[0] = first;
  count[0] = rows;
  H5Sselect_hyperslab(file_space, H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr);
  return Id(H5Screate_simple(rank, count.data(), nullptr), H5Sclose);
}
}  // namespace

// Writes row `index` of a growing dataset (extending it to index + 1 rows).
bool WriteRow(hid_t group, const char* name, hid_t mem_type, hsize_t index, const void* data) {
  Id set(H5Dopen2(group, name, H5P_DEFAULT), H5Dclose);
  if (!set.ok()) return false;
  std::vector<hsize_t> dims = Dims(set);
  dims[0] = index + 1;
  if (H5Dset_extent(set, dims.data()) < 0) return false;
  Id file_space(H5Dget_space(set), H5Sclose);
  Id mem_space = SelectRows(file_space, index);
  return H5Dwrite(set, mem_type, mem_space, file_space, H5P_DEFAULT, data) >= 0 && set.Close();
}

bool ReadRow(hid_t group, const char* name, hid_t mem_type, hsize_t index, void* data) { return ReadRows(group, name, mem_type, index, 1, data); }

bool ReadRows(hid_t group, const char* name, hid_t mem_type, hsize_t first, hsize_t rows, void* data) {
  Id set(H5Dopen2(group, name, H5P_DEFAULT), H5Dclose);
  if (!set.ok()) return false;
  if (first + rows > Dims(set)[0]) return false;
  if (rows == 0) return true;
  Id file_space(H5Dget_space(set), H5Sclose);
  Id mem_space = SelectRows(file_space, first, rows);
  return H5Dread(set, mem_type, mem_space, file_space, H5P_DEFAULT, data) >= 0;
}

bool Truncate(hid_t group, const char* name, hsize_t rows) {
  Id set(H5Dopen2(group, name, H5P_DEFAULT), H5Dclose);
  if (!set.ok()) return false;
  std::vector<hsize_t> dims = Dims(set);
  if (dims[0] <= rows) return true;
  dims[0] = rows;
  return H5Dset_extent(set, dims.data()) >= 0 && set.Close();
}

}  // namespace kgd::hdf5
