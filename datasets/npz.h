// numpy's .npz archives: a zip file of .npy members, stored or deflated
// (numpy.savez, numpy.savez_compressed), zip64 records included. Read whole
// into memory: meant for small archives (a frame's camera), not for rasters.
// https://pkware.cachefly.net/webdocs/casestudies/APPNOTE.TXT (sections 4.3, 4.4, 4.5.3)
#pragma once

#include <map>
#include <string>

#include "datasets/npy.h"

namespace hdabench::datasets {

// The members of zip bytes, name -> uncompressed bytes. Returns false with
// `error` (without the file name) for a missing end-of-central-directory
// record, a record or member outside the bytes, an encrypted member, a
// compression method other than stored (0) or deflate (8), a member whose
// size or CRC-32 does not match its record, or a repeated name. The members
// together are limited to `max_member_bytes` uncompressed.
bool ParseZipMembers(const std::string& bytes, std::map<std::string, std::string>* members,
                     std::string* error, std::size_t max_member_bytes = std::size_t{1} << 28);

// The arrays of an .npz file, by name without ".npy" (numpy's keys), each
// '<f4' or '<f8' (ParseNpyAsDoubles). Throws InputError "path: ..." naming
// the member when the file cannot be read, is not a zip archive, or a member
// is not such an array.
std::map<std::string, NpyDoubles> ReadNpzArrays(const std::string& path);

}  // namespace hdabench::datasets
