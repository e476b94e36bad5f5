// Small helpers over HDF5's C API: an RAII identifier, attributes, fixed and growing (extendible,
// chunked, checksummed) datasets read and written a row at a time. The design file's format is
// store/design_file.h; this file knows no format. Every function returns false on any HDF5 error
// (SilenceHdf5 keeps HDF5 from printing them).
#pragma once

#include <hdf5.h>

#include <string>
#include <vector>

namespace kgd::hdf5 {

// RAII for HDF5 identifiers.
struct Id {
  hid_t id = H5I_INVALID_HID;
  herr_t (*close)(hid_t) = nullptr;
  Id() = default;
  Id(hid_t i, herr_t (*c)(hid_t)) : id(i), close(c) {}
  Id(Id&& o) noexcept : id(o.id), close(o.close) { o.id = H5I_INVALID_HID; }
  Id& operator=(Id&& o) noexcept {
    if (this != &o) {
      reset();
      id = o.id;
      close = o.close;
      o.id = H5I_INVALID_HID;
    }
    return *this;
  }
  ~Id() { reset(); }
  void reset() {
    if (id >= 0 && close) close(id);
    id = H5I_INVALID_HID;
  }
  // Closes now and says whether that worked. A writer must: closing a dataset writes its cached chunks,
  // and a chunk that fails to write there (a full disk) is dropped while the write and a later flush
  // report success.
  bool Close() {
    const bool ok = id < 0 || !close || close(id) >= 0;
    id = H5I_INVALID_HID;
    return ok;
  }
  bool ok() const { return id >= 0; }
  operator hid_t() const { return id; }
};

// Turns off HDF5's automatic error printing (once per thread: HDF5 keeps error stacks per thread) and
// records each failure for LastHdf5Error instead.
void SilenceHdf5();

// What the last failed HDF5 call of this thread reported, for an error message: the system's error
// where HDF5 met one ("No space left on device (ENOSPC)", "Input/output error (EIO)"), else HDF5's own
// description; "an HDF5 error" when none was recorded. Reading it clears the record.
std::string LastHdf5Error();
// The system error number behind the last failed HDF5 call of this thread (ENOSPC, EIO, ...), 0 when
// there was none; LastHdf5Error clears it too.
int LastHdf5Errno();
// Forgets the recorded failure: called before an operation whose failure LastHdf5Error will explain.
void ClearHdf5Error();

// Fixed-length UTF-8 string and 32-bit integer attributes.
bool WriteStringAttribute(hid_t obj, const char* name, const std::string& value);
bool ReadStringAttribute(hid_t obj, const char* name, std::string* value);
bool WriteIntAttribute(hid_t obj, const char* name, int value);
bool ReadIntAttribute(hid_t obj, const char* name, int* value);

// A fixed-size dataset written at once (row-major data), in one checksummed chunk.
bool WriteFixed(hid_t group, const char* name, hid_t file_type, hid_t mem_type, const std::vector<hsize_t>& dims, const void* data);
// The current extent of an open dataset.
std::vector<hsize_t> Dims(hid_t set);
// The shape of a dataset, or empty if it does not exist.
std::vector<hsize_t> Shape(hid_t group, const char* name);
bool ReadAll(hid_t group, const char* name, hid_t mem_type, void* data);

// How a growing dataset is stored: scalars 64 rows to a chunk; arrays a row to a chunk, deflated
// (with shuffle) or raw. Every chunk carries a Fletcher-32 checksum.
enum class Storage { kScalars, kDeflated, kRaw };

// An extendible dataset of rows of shape `row` (no rows yet).
bool CreateGrowing(hid_t group, const char* name, hid_t file_type, const std::vector<hsize_t>& row,
                   Storage storage = Storage::kScalars);
// Writes row `index` of a growing dataset (extending it to index + 1 rows).
bool WriteRow(hid_t group, const char* name, hid_t mem_type, hsize_t index, const void* data);
bool ReadRow(hid_t group, const char* name, hid_t mem_type, hsize_t index, void* data);
// Reads rows [first, first + rows) into `data` (rows x row size, row-major); false past the end.
bool ReadRows(hid_t group, const char* name, hid_t mem_type, hsize_t first, hsize_t rows, void* data);
// Keeps the first `rows` rows.
bool Truncate(hid_t group, const char* name, hsize_t rows);

}  // namespace kgd::hdf5
