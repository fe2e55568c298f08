#include "records/internal/mat5_check.h"

#include <zlib.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <string>

namespace kcrig {
namespace {

// MAT-file data types (miINT8 ...) and array classes (mxCELL_CLASS ...).
enum : std::uint32_t { kMiInt8 = 1, kMiInt32 = 5, kMiUint32 = 6 };
enum : std::uint32_t { kMiMatrix = 14, kMiCompressed = 15 };
enum : std::uint32_t { kCell = 1, kStruct = 2, kChar = 4, kSparse = 5 };
constexpr std::uint32_t kComplexFlag = 0x0800;
constexpr int kMaxDepth = 16;
constexpr std::size_t kHeaderBytes = 128;

// Bytes per element of data type `type`; 0 for a type that holds no array
// data.
std::size_t TypeSize(std::uint32_t type) {
  switch (type) {
    case 1:
    case 2:
    case 16:
      return 1;  // int8, uint8, utf8
    case 3:
    case 4:
    case 17:
      return 2;  // int16, uint16, utf16
    case 5:
    case 6:
    case 7:
    case 18:
      return 4;  // int32, uint32, single, utf32
    case 9:
    case 12:
    case 13:
      return 8;  // double, int64, uint64
    default:
      return 0;
  }
}

std::uint32_t Le32(const unsigned char* p) {
  return static_cast<std::uint32_t>(p[0]) |
         static_cast<std::uint32_t>(p[1]) << 8 |
         static_cast<std::uint32_t>(p[2]) << 16 |
         static_cast<std::uint32_t>(p[3]) << 24;
}

struct Element {
  std::uint32_t type = 0;
  std::size_t offset = 0;  // first data byte
  std::size_t size = 0;    // data bytes
  std::size_t next = 0;    // the following element's tag
};

// At most this many arrays (variables, cells, struct fields): libmatio
// allocates about a hundred bytes for each, however small, on every read
// that passes it.
constexpr std::size_t kMaxArrays = 100000;

// Bytes per element of array class `array_class` in memory (what libmatio
// allocates, whatever the stored type).
std::size_t ClassSize(std::uint32_t array_class) {
  switch (array_class) {
    case 4:
    case 10:
    case 11:
      return 2;  // char (UTF-16), int16, uint16
    case 8:
    case 9:
      return 1;  // int8, uint8
    case 7:
    case 12:
    case 13:
      return 4;  // single, int32, uint32
    default:
      return 8;  // double, int64, uint64
  }
}

class Checker {
 public:
  Checker(const std::string& path, std::size_t budget)
      : path_(path), budget_(budget) {}

  Status File(const std::string& bytes) {
    if (bytes.size() < kHeaderBytes) return Error("shorter than its header");
    const auto* data = reinterpret_cast<const unsigned char*>(bytes.data());
    if (data[124] == 0x00 && data[125] == 0x02) {
      return Status::Error(path_ +
                           ": a MAT-file v7.3 (HDF5); save it with -v7 "
                           "(MATLAB: save(name, '-v7')) to read it here");
    }
    // Level 5 (version 0x0100), little-endian: libmatio would read any
    // other version as a level-4 file, whose header this check never sees.
    if (data[126] != 'I' || data[127] != 'M' || data[124] != 0x00 ||
        data[125] != 0x01) {
      return Error("not a little-endian level-5 MAT-file");
    }
    return Elements(data, kHeaderBytes, bytes.size(), 0);
  }

 private:
  Status Error(const std::string& what) const {
    return Status::Error(path_ + ": not a readable MAT-file (" + what + ")");
  }

  // The element whose tag starts at `pos`, within [pos, end).
  Status Tag(const unsigned char* data, std::size_t pos, std::size_t end,
             Element* e) const {
    if (end < pos || end - pos < 8) return Error("a data element is cut short");
    const std::uint32_t first = Le32(data + pos);
    if ((first >> 16) != 0) {  // the small format: data in the tag's 2nd word
      e->type = first & 0xffff;
      e->size = first >> 16;
      if (e->size > 4) return Error("a small data element over 4 bytes");
      e->offset = pos + 4;
      e->next = pos + 8;
      return Status::Ok();
    }
    e->type = first;
    e->size = Le32(data + pos + 4);
    e->offset = pos + 8;
    if (e->size > end - e->offset) {
      return Error("a data element larger than what holds it");
    }
    // libmatio moves past an array by exactly its size: one that is not a
    // whole number of 8-byte words would put the next tag where this check
    // did not look.
    if (e->type == kMiMatrix && e->size % 8 != 0) {
      return Error("an array whose size is not a multiple of 8 bytes");
    }
    // Padded to 8 bytes, except a compressed element.
    const std::size_t padded =
        e->type == kMiCompressed ? e->size : (e->size + 7) / 8 * 8;
    e->next = e->offset + std::min(padded, end - e->offset);
    return Status::Ok();
  }

  Status Elements(const unsigned char* data, std::size_t pos, std::size_t end,
                  int depth) {
    if (depth > kMaxDepth) return Error("nested too deeply");
    while (pos < end) {
      Element e;
      KCRIG_RETURN_IF_ERROR(Tag(data, pos, end, &e));
      if (e.type == kMiCompressed) {
        KCRIG_RETURN_IF_ERROR(Compressed(data + e.offset, e.size, depth));
      } else if (e.type == kMiMatrix) {
        KCRIG_RETURN_IF_ERROR(Matrix(data, e.offset, e.offset + e.size, depth));
      } else {
        return Error("a variable of data type " + std::to_string(e.type));
      }
      pos = e.next;
    }
    return Status::Ok();
  }

  Status Compressed(const unsigned char* data, std::size_t size, int depth) {
    std::string inflated;
    z_stream stream{};
    if (inflateInit(&stream) != Z_OK) return Error("zlib");
    stream.next_in = const_cast<unsigned char*>(data);
    stream.avail_in =
        static_cast<uInt>(std::min<std::size_t>(size, UINT32_MAX));
    int rc = Z_OK;
    unsigned char chunk[1 << 16];
    while (rc == Z_OK) {
      stream.next_out = chunk;
      stream.avail_out = sizeof chunk;
      rc = inflate(&stream, Z_NO_FLUSH);
      const std::size_t produced = sizeof chunk - stream.avail_out;
      if (produced > budget_ - std::min(budget_, inflated_)) {
        inflateEnd(&stream);
        return Error("compressed data inflates beyond " +
                     std::to_string(budget_ >> 20) + " MB");
      }
      inflated_ += produced;
      inflated.append(reinterpret_cast<char*>(chunk), produced);
      if (rc == Z_BUF_ERROR && stream.avail_in == 0) break;
    }
    inflateEnd(&stream);
    if (rc != Z_STREAM_END) return Error("corrupt compressed data");
    return Elements(reinterpret_cast<const unsigned char*>(inflated.data()), 0,
                    inflated.size(), depth + 1);
  }

  // One array (the data of a miMATRIX element) in [pos, end).
  Status Matrix(const unsigned char* data, std::size_t pos, std::size_t end,
                int depth) {
    if (depth > kMaxDepth) return Error("nested too deeply");
    if (++arrays_ > kMaxArrays) {
      return Error("more than " + std::to_string(kMaxArrays) + " arrays");
    }
    if (pos == end) return Status::Ok();  // an empty array
    Element flags, dims, name;
    KCRIG_RETURN_IF_ERROR(Tag(data, pos, end, &flags));
    if (flags.type != kMiUint32 || flags.size != 8) {
      return Error("an array without its flags");
    }
    const std::uint32_t flag_word = Le32(data + flags.offset);
    const std::uint32_t array_class = flag_word & 0xff;
    KCRIG_RETURN_IF_ERROR(Tag(data, flags.next, end, &dims));
    if (dims.type != kMiInt32 || dims.size < 8 || dims.size % 4 != 0) {
      return Error("an array without its dimensions");
    }
    std::size_t count = 1;
    for (std::size_t k = 0; k < dims.size; k += 4) {
      const std::uint32_t d = Le32(data + dims.offset + k);
      if (d > INT32_MAX || (d > 0 && count > (std::size_t{1} << 40) / d)) {
        return Error("an array's dimensions are out of range");
      }
      count *= d;
    }
    KCRIG_RETURN_IF_ERROR(Tag(data, dims.next, end, &name));
    if (name.type != kMiInt8) return Error("an array without its name");
    std::size_t pos_data = name.next;
    switch (array_class) {
      case kCell:
        return Children(data, pos_data, end, count, depth);
      case kStruct: {
        Element length, names;
        KCRIG_RETURN_IF_ERROR(Tag(data, pos_data, end, &length));
        if (length.type != kMiInt32 || length.size != 4) {
          return Error("a struct without its field name length");
        }
        const std::uint32_t field_length = Le32(data + length.offset);
        KCRIG_RETURN_IF_ERROR(Tag(data, length.next, end, &names));
        if (field_length == 0 || names.size % field_length != 0) {
          return Error("a struct's field names");
        }
        const std::size_t fields = names.size / field_length;
        if (fields > 0 && count > (std::size_t{1} << 40) / fields) {
          return Error("a struct too large");
        }
        return Children(data, names.next, end, count * fields, depth);
      }
      case kSparse:
        return Error("a sparse array (kcrig reads full arrays)");
      default:
        break;
    }
    if (array_class != kChar && (array_class < 6 || array_class > 15)) {
      return Error("an array of class " + std::to_string(array_class));
    }
    const int parts = (flag_word & kComplexFlag) ? 2 : 1;
    for (int part = 0; part < parts; ++part) {
      Element values;
      KCRIG_RETURN_IF_ERROR(Tag(data, pos_data, end, &values));
      const std::size_t size = TypeSize(values.type);
      if (size == 0 || values.size != count * size) {
        return Error("an array whose data does not match its dimensions");
      }
      // What libmatio will hold in memory, at its class's size.
      const std::size_t held = count * ClassSize(array_class);
      if (held > budget_ - std::min(budget_, held_)) {
        return Error("arrays larger than " + std::to_string(budget_ >> 20) +
                     " MB in memory");
      }
      held_ += held;
      pos_data = values.next;
    }
    return Status::Ok();
  }

  // `count` arrays (cells, struct fields), each a miMATRIX element.
  Status Children(const unsigned char* data, std::size_t pos, std::size_t end,
                  std::size_t count, int depth) {
    for (std::size_t k = 0; k < count; ++k) {
      Element child;
      KCRIG_RETURN_IF_ERROR(Tag(data, pos, end, &child));
      if (child.type != kMiMatrix) return Error("a cell that is not an array");
      KCRIG_RETURN_IF_ERROR(
          Matrix(data, child.offset, child.offset + child.size, depth + 1));
      pos = child.next;
    }
    return Status::Ok();
  }

  const std::string& path_;
  const std::size_t budget_;
  std::size_t inflated_ = 0;
  std::size_t held_ = 0;
  std::size_t arrays_ = 0;
};

}  // namespace

Status CheckMat5Structure(const std::string& bytes, const std::string& path,
                          std::size_t inflate_budget) {
  return Checker(path, inflate_budget).File(bytes);
}

}  // namespace kcrig
