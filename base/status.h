// Errors cross module boundaries as values, never as exceptions (Ceres style).
#ifndef KCRIG_BASE_STATUS_H_
#define KCRIG_BASE_STATUS_H_

#include <cstdio>
#include <string>
#include <utility>

namespace kcrig {

// `text` with every control character (C0, DEL, C1, the line separators and
// the bidirectional controls) and every byte that is not part of valid
// UTF-8 shown as \xNN: a message that echoes input (a
// CSV field, a config value, a path) must not drive the terminal it is
// printed on (a title set, a cleared screen) nor break its one line.
inline std::string EscapeControl(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  auto escape = [&out](unsigned char byte) {
    char code[5];
    std::snprintf(code, sizeof(code), "\\x%02x", byte);
    out += code;
  };
  for (size_t i = 0; i < text.size();) {
    const auto byte = static_cast<unsigned char>(text[i]);
    if (byte >= 0x20 && byte < 0x7f) {
      out += static_cast<char>(byte);
      ++i;
      continue;
    }
    // A UTF-8 sequence: its length from the lead byte, its code point.
    const int length = byte >= 0xf0 && byte < 0xf5   ? 4
                       : byte >= 0xe0 && byte < 0xf0 ? 3
                       : byte >= 0xc2 && byte < 0xe0 ? 2
                                                     : 0;
    bool valid = length > 0 && i + length <= text.size();
    unsigned code_point = length > 0 ? byte & (0x7f >> length) : 0;
    for (int k = 1; valid && k < length; ++k) {
      const auto next = static_cast<unsigned char>(text[i + k]);
      valid = (next & 0xc0) == 0x80;
      code_point = (code_point << 6) | (next & 0x3f);
    }
    const bool overlong = (length == 3 && code_point < 0x800) ||
                          (length == 4 && code_point < 0x10000);
    // Line separators and bidirectional controls reorder or break the
    // line a reader sees: escaped like control characters.
    const bool reorders = (code_point >= 0x2028 && code_point <= 0x202e) ||
                          (code_point >= 0x2066 && code_point <= 0x2069);
    if (valid && !overlong && !reorders && code_point > 0x9f &&
        code_point <= 0x10ffff &&
        !(code_point >= 0xd800 && code_point < 0xe000)) {
      out.append(text, i, length);
      i += length;
    } else if (valid && !overlong && reorders) {
      for (int k = 0; k < length; ++k) {
        escape(static_cast<unsigned char>(text[i + k]));
      }
      i += length;
    } else {
      escape(byte);
      ++i;
    }
  }
  return out;
}

class Status {
 public:
  static Status Ok() { return Status(); }
  static Status Error(std::string message) {
    Status status;
    status.ok_ = false;
    status.message_ = EscapeControl(message);
    return status;
  }

  bool ok() const { return ok_; }
  // One line, naming the file, line or field at fault; control characters
  // escaped (EscapeControl).
  const std::string& message() const { return message_; }

 private:
  bool ok_ = true;
  std::string message_;
};

}  // namespace kcrig

// Returns the Status of `expr` from the enclosing function when it is an
// error.
#define KCRIG_RETURN_IF_ERROR(expr)         \
  do {                                      \
    const ::kcrig::Status _status = (expr); \
    if (!_status.ok()) return _status;      \
  } while (0)

#endif  // KCRIG_BASE_STATUS_H_
