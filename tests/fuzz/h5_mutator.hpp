#pragma once
// Structure-aware mutation of GrainTwin's HDF5 files for the fuzz targets.
//
// Byte-level mutation of a whole .h5 file mostly exercises libhdf5's own parser (which is not ours
// and crashes on some damaged byte streams). Instead, the fuzz input here is a small program of
// edits to OUR layer of a valid file: drop or swap datasets, groups and attributes, change a
// dataset's shape (truncate or extend a table, change the rank, declare a huge extent that holds no
// data), its element type, or its values (NaN, infinities, huge, negative, zero, bad strings), and
// change the kind, version and other attributes. The edited file is then handed to our reader.
//
// Input format, repeated up to 4 times: op (1 byte: 0 delete, 1 swap, 2 reshape, 3 retype, 4 set
// values, 5 dataset <-> group, 6 attribute length/type), object (2 bytes, little endian: index in
// the sorted listing of groups, datasets and attributes; 0xffff: 1 length byte and the name follow,
// "/a/b" or "/a/b@attribute"), parameter (8 bytes, little endian: which variant of the op). With
// GRAINTWIN_FUZZ_TRACE set, every edit is printed to stderr.
#include <cstddef>
#include <cstdint>
#include <filesystem>

namespace graintwin::fuzz {

/// Copies `base` to `out`, then applies the edits that `data` encodes (at most a few; an empty
/// input edits nothing). Every edit that HDF5 refuses is skipped.
void mutate_h5(const std::filesystem::path& base, const std::filesystem::path& out, const std::uint8_t* data,
               std::size_t size);

/// The fuzz entry of a structure-aware target: mutates the valid file `base` as `data` says into a scratch file and
/// hands its path to `read`. Without edits the reader must accept the base file; with edits it
/// must return or throw graintwin::Error.
void fuzz_h5_reader(const std::string& reader, const std::filesystem::path& base, const std::uint8_t* data, std::size_t size,
                    void (*read)(const std::filesystem::path&));

}  // namespace graintwin::fuzz
