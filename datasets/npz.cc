#include "datasets/npz.h"

#include <cstdint>
#include <fstream>
#include <sstream>

#include <zlib.h>

#include "tools/util/error.h"

namespace hdabench::datasets {

namespace {

constexpr std::uint32_t kEndOfCentralDirectory = 0x06054b50;
constexpr std::uint32_t kZip64EndLocator = 0x07064b50;
constexpr std::uint32_t kZip64End = 0x06064b50;
constexpr std::uint32_t kCentralHeader = 0x02014b50;
constexpr std::uint32_t kLocalHeader = 0x04034b50;
constexpr std::uint16_t kZip64ExtraId = 0x0001;

// Little-endian reads that fail (return false) instead of reading past the end.
class Reader {
 public:
  explicit Reader(const std::string& bytes) : bytes_(bytes) {}
  bool U16(std::uint64_t at, std::uint16_t* v) const { return Read(at, 2, v); }
  bool U32(std::uint64_t at, std::uint32_t* v) const { return Read(at, 4, v); }
  bool U64(std::uint64_t at, std::uint64_t* v) const { return Read(at, 8, v); }
  bool Has(std::uint64_t at, std::uint64_t n) const { return at <= bytes_.size() && n <= bytes_.size() - at; }

 private:
  template <class T>
  bool Read(std::uint64_t at, int n, T* v) const {
    if (!Has(at, static_cast<std::uint64_t>(n))) return false;
    std::uint64_t value = 0;
    for (int i = 0; i < n; ++i) {
      value |= static_cast<std::uint64_t>(static_cast<unsigned char>(bytes_[at + i])) << (8 * i);
    }
    *v = static_cast<T>(value);
    return true;
  }
  const std::string& bytes_;
};

bool Fail(const std::string& message, std::string* error) {
  *error = message;
  return false;
}

// Raw deflate (no zlib header) of exactly `size` output bytes.
bool Inflate(const char* data, std::uint64_t length, std::uint64_t size, std::string* out,
             std::string* error) {
  out->assign(static_cast<size_t>(size), '\0');
  z_stream stream{};
  if (inflateInit2(&stream, -MAX_WBITS) != Z_OK) return Fail("zlib cannot start", error);
  stream.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data));
  stream.avail_in = static_cast<uInt>(length);
  stream.next_out = reinterpret_cast<Bytef*>(out->data());
  stream.avail_out = static_cast<uInt>(size);
  const int status = inflate(&stream, Z_FINISH);
  const std::uint64_t produced = stream.total_out;
  inflateEnd(&stream);
  if (status != Z_STREAM_END || produced != size) {
    return Fail("its deflate data are corrupt or do not give " + std::to_string(size) + " bytes", error);
  }
  return true;
}

}  // namespace

bool ParseZipMembers(const std::string& bytes, std::map<std::string, std::string>* members,
                     std::string* error, std::size_t max_member_bytes) {
  members->clear();
  const Reader r(bytes);
  // The end-of-central-directory record: the last signature within its
  // largest size (22 bytes and a comment of up to 65535) from the end.
  if (bytes.size() < 22) return Fail("is not a zip archive (too short)", error);
  std::uint64_t end = bytes.size() - 22;
  const std::uint64_t lowest = bytes.size() > 22 + 65535 ? bytes.size() - 22 - 65535 : 0;
  for (;; --end) {
    std::uint32_t signature = 0;
    r.U32(end, &signature);
    if (signature == kEndOfCentralDirectory) break;
    if (end == lowest) return Fail("is not a zip archive (no end-of-central-directory record)", error);
  }
  std::uint16_t entries16 = 0;
  std::uint32_t directory_size32 = 0, directory_offset32 = 0;
  r.U16(end + 10, &entries16);
  r.U32(end + 12, &directory_size32);
  r.U32(end + 16, &directory_offset32);
  std::uint64_t entries = entries16, directory_offset = directory_offset32;
  if (entries16 == 0xFFFF || directory_offset32 == 0xFFFFFFFF || directory_size32 == 0xFFFFFFFF) {
    std::uint32_t signature = 0;
    std::uint64_t zip64_end = 0;
    if (end < 20 || !r.U32(end - 20, &signature) || signature != kZip64EndLocator ||
        !r.U64(end - 20 + 8, &zip64_end) || !r.U32(zip64_end, &signature) || signature != kZip64End ||
        !r.U64(zip64_end + 32, &entries) || !r.U64(zip64_end + 48, &directory_offset)) {
      return Fail("has a damaged zip64 end-of-central-directory record", error);
    }
  }
  std::uint64_t at = directory_offset;
  std::uint64_t total_bytes = 0;  // uncompressed, over every member
  for (std::uint64_t i = 0; i < entries; ++i) {
    const std::string which = "central directory entry " + std::to_string(i + 1);
    std::uint32_t signature = 0, crc = 0, compressed32 = 0, size32 = 0, local32 = 0;
    std::uint16_t flags = 0, method = 0, name_length = 0, extra_length = 0, comment_length = 0;
    if (!r.U32(at, &signature) || signature != kCentralHeader || !r.U16(at + 8, &flags) ||
        !r.U16(at + 10, &method) || !r.U32(at + 16, &crc) || !r.U32(at + 20, &compressed32) ||
        !r.U32(at + 24, &size32) || !r.U16(at + 28, &name_length) || !r.U16(at + 30, &extra_length) ||
        !r.U16(at + 32, &comment_length) || !r.U32(at + 42, &local32) ||
        !r.Has(at + 46, std::uint64_t{name_length} + extra_length + comment_length)) {
      return Fail("has a damaged " + which, error);
    }
    const std::string name = bytes.substr(at + 46, name_length);
    std::uint64_t compressed = compressed32, size = size32, local = local32;
    // The zip64 extra field holds, in this order, the values whose 32-bit
    // field is 0xFFFFFFFF.
    for (std::uint64_t e = at + 46 + name_length; e + 4 <= at + 46 + name_length + extra_length;) {
      std::uint16_t id = 0, length = 0;
      r.U16(e, &id);
      r.U16(e + 2, &length);
      if (id == kZip64ExtraId) {
        std::uint64_t field = e + 4;
        for (std::uint64_t* value : {&size, &compressed, &local}) {
          const bool wide = (value == &size && size32 == 0xFFFFFFFF) ||
                            (value == &compressed && compressed32 == 0xFFFFFFFF) ||
                            (value == &local && local32 == 0xFFFFFFFF);
          if (!wide) continue;
          if (field + 8 > e + 4 + length || !r.U64(field, value)) {
            return Fail("member '" + name + "' has a damaged zip64 extra field", error);
          }
          field += 8;
        }
      }
      e += 4 + std::uint64_t{length};
    }
    at += 46 + std::uint64_t{name_length} + extra_length + comment_length;
    const std::string member = "member '" + name + "'";
    if ((flags & 0x1) != 0) return Fail(member + " is encrypted", error);
    if (method != 0 && method != 8) {
      return Fail(member + " uses compression method " + std::to_string(method) +
                      "; expected stored (0) or deflate (8)",
                  error);
    }
    if (size > max_member_bytes - total_bytes) {
      return Fail(member + " holds " + std::to_string(size) + " bytes; at most " +
                      std::to_string(max_member_bytes) + " are read from an archive",
                  error);
    }
    total_bytes += size;
    if (members->count(name) != 0) return Fail(member + " is repeated", error);
    std::uint16_t local_name = 0, local_extra = 0;
    if (!r.U32(local, &signature) || signature != kLocalHeader || !r.U16(local + 26, &local_name) ||
        !r.U16(local + 28, &local_extra)) {
      return Fail(member + " has a damaged local header", error);
    }
    const std::uint64_t data = local + 30 + local_name + local_extra;
    if (!r.Has(data, compressed)) return Fail(member + " runs past the end of the archive", error);
    std::string content;
    if (method == 0) {
      if (compressed != size) return Fail(member + " is stored with two different sizes", error);
      content = bytes.substr(data, size);
    } else {
      std::string inflate_error;
      if (!Inflate(bytes.data() + data, compressed, size, &content, &inflate_error)) {
        return Fail(member + ": " + inflate_error, error);
      }
    }
    const uLong actual = crc32(crc32(0L, Z_NULL, 0), reinterpret_cast<const Bytef*>(content.data()),
                               static_cast<uInt>(content.size()));
    if (actual != crc) return Fail(member + " fails its CRC-32 check", error);
    members->emplace(name, std::move(content));
  }
  return true;
}

std::map<std::string, NpyDoubles> ReadNpzArrays(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot be read");
  std::stringstream text;
  text << in.rdbuf();
  std::map<std::string, std::string> members;
  std::string error;
  if (!ParseZipMembers(text.str(), &members, &error)) throw InputError(path + ": " + error);
  std::map<std::string, NpyDoubles> arrays;
  for (const auto& [name, bytes] : members) {
    const std::string suffix = ".npy";
    if (name.size() <= suffix.size() || name.compare(name.size() - suffix.size(), suffix.size(), suffix) != 0) {
      throw InputError(path + ": member '" + name + "' is not a .npy array");
    }
    NpyDoubles array;
    if (!ParseNpyAsDoubles(bytes, &array, &error)) throw InputError(path + ": member '" + name + "' " + error);
    arrays.emplace(name.substr(0, name.size() - suffix.size()), std::move(array));
  }
  return arrays;
}

}  // namespace hdabench::datasets
