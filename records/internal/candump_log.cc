#include "records/internal/candump_log.h"

#include <cstdio>
#include <fstream>

#include "base/input_file.h"

namespace kcrig {
namespace {

constexpr std::uint32_t kErrorFlag = 0x20000000u;  // CAN_ERR_FLAG

int HexDigit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  return -1;
}

bool ParseDecimal(std::string_view text, std::int64_t* value) {
  if (text.empty() || text.size() > 18) return false;
  std::int64_t v = 0;
  for (char c : text) {
    if (c < '0' || c > '9') return false;
    v = v * 10 + (c - '0');
  }
  *value = v;
  return true;
}

}  // namespace

std::size_t FormatCandumpLine(const TimedCanFrame& timed,
                              std::string_view interface, char* out) {
  const CanFrame& f = timed.frame;
  const std::int64_t seconds = timed.time_us / 1000000;
  const std::int64_t micros = timed.time_us % 1000000;
  if (interface.size() > 15) interface = interface.substr(0, 15);
  int n = std::snprintf(out, kCandumpLineMax, "(%010lld.%06lld) %.*s ",
                        static_cast<long long>(seconds),
                        static_cast<long long>(micros),
                        static_cast<int>(interface.size()), interface.data());
  if (f.error) {
    n += std::snprintf(out + n, kCandumpLineMax - n, "%08X#",
                       (f.id & 0x1FFFFFFFu) | kErrorFlag);
  } else if (f.extended) {
    n += std::snprintf(out + n, kCandumpLineMax - n, "%08X#",
                       f.id & 0x1FFFFFFFu);
  } else {
    n += std::snprintf(out + n, kCandumpLineMax - n, "%03X#", f.id & 0x7FFu);
  }
  const int dlc = f.dlc > 8 ? 8 : f.dlc;
  if (f.remote) {
    out[n++] = 'R';
    if (dlc > 0) out[n++] = static_cast<char>('0' + dlc);
  } else {
    static const char kHex[] = "0123456789ABCDEF";
    for (int k = 0; k < dlc; ++k) {
      out[n++] = kHex[f.data[k] >> 4];
      out[n++] = kHex[f.data[k] & 15];
    }
  }
  out[n++] = '\n';
  out[n] = '\0';
  return static_cast<std::size_t>(n);
}

Status ParseCandumpLine(std::string_view line, const std::string& where,
                        CandumpRecord* record) {
  while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) {
    line.remove_suffix(1);
  }
  auto fail = [&](const std::string& what) {
    return Status::Error(where + ": " + what +
                         " (expected '(SECONDS.MICROS) IFACE ID#DATA')");
  };
  if (line.size() < 2 || line[0] != '(') return fail("no time stamp");
  const size_t close = line.find(')');
  if (close == std::string_view::npos) return fail("time stamp not closed");
  const std::string_view stamp = line.substr(1, close - 1);
  const size_t dot = stamp.find('.');
  std::int64_t seconds = 0, micros = 0;
  if (dot == std::string_view::npos || stamp.size() - dot - 1 != 6 ||
      !ParseDecimal(stamp.substr(0, dot), &seconds) ||
      !ParseDecimal(stamp.substr(dot + 1), &micros) || seconds > 1e11) {
    return fail("bad time stamp '" + std::string(stamp) + "'");
  }
  std::string_view rest = line.substr(close + 1);
  if (rest.empty() || rest[0] != ' ') return fail("no interface");
  rest.remove_prefix(1);
  const size_t space = rest.find(' ');
  if (space == std::string_view::npos || space == 0 || space > 15) {
    return fail("bad interface name");
  }
  record->interface = std::string(rest.substr(0, space));
  for (char c : record->interface) {
    if (c <= ' ' || c > '~') return fail("bad interface name");
  }
  std::string_view frame_text = rest.substr(space + 1);
  const size_t hash = frame_text.find('#');
  if (hash == std::string_view::npos) return fail("no '#' in the frame");
  if (hash + 1 < frame_text.size() && frame_text[hash + 1] == '#') {
    return Status::Error(where + ": CAN FD frames are not supported");
  }
  const std::string_view id_text = frame_text.substr(0, hash);
  if (id_text.size() != 3 && id_text.size() != 8) {
    return fail("id '" + std::string(id_text) + "' is not 3 or 8 hex digits");
  }
  std::uint32_t id = 0;
  for (char c : id_text) {
    const int d = HexDigit(c);
    if (d < 0) return fail("id '" + std::string(id_text) + "' is not hex");
    id = id << 4 | static_cast<std::uint32_t>(d);
  }
  CanFrame& f = record->frame.frame;
  f = CanFrame();
  if (id_text.size() == 3) {
    if (id > 0x7FF) return fail("11-bit id above 7FF");
    f.id = id;
  } else if (id & kErrorFlag) {
    f.error = true;
    f.id = id & 0x1FFFFFFFu;
  } else {
    if (id > 0x1FFFFFFFu) return fail("29-bit id above 1FFFFFFF");
    f.extended = true;
    f.id = id;
  }
  std::string_view data = frame_text.substr(hash + 1);
  // A classic frame may carry its raw DLC 9..F after '_': not used here.
  const size_t underscore = data.find('_');
  if (underscore != std::string_view::npos) {
    if (data.size() != underscore + 2 || HexDigit(data[underscore + 1]) < 9) {
      return fail("bad DLC suffix");
    }
    data = data.substr(0, underscore);
  }
  if (!data.empty() && (data[0] == 'R' || data[0] == 'r')) {
    f.remote = true;
    if (data.size() == 2 && data[1] >= '0' && data[1] <= '8') {
      f.dlc = static_cast<std::uint8_t>(data[1] - '0');
    } else if (data.size() != 1) {
      return fail("bad remote frame '" + std::string(data) + "'");
    }
  } else {
    if (data.size() % 2 != 0 || data.size() > 16) {
      return fail("data '" + std::string(data) +
                  "' is not 0 to 8 bytes of hex");
    }
    for (size_t k = 0; k < data.size(); k += 2) {
      const int hi = HexDigit(data[k]), lo = HexDigit(data[k + 1]);
      if (hi < 0 || lo < 0) {
        return fail("data '" + std::string(data) + "' is not hex");
      }
      f.data[k / 2] = static_cast<std::uint8_t>(hi << 4 | lo);
    }
    f.dlc = static_cast<std::uint8_t>(data.size() / 2);
  }
  record->frame.time_us = seconds * 1000000 + micros;
  return Status::Ok();
}

Status ReadCandumpLog(const std::string& path,
                      std::vector<CandumpRecord>* records) {
  records->clear();
  // An hour of a 1 kHz rig's bus (six frames a cycle) is about 1.2 GB.
  constexpr std::uintmax_t kMaxCanLogBytes = 2u << 30;
  KCRIG_RETURN_IF_ERROR(CheckInputFile(path, kMaxCanLogBytes));
  std::ifstream in(path);
  if (!in) return Status::Error(path + ": cannot open the CAN log");
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    if (line.size() > 256) {
      return Status::Error(path + ":" + std::to_string(number) +
                           ": line too long for a candump -l log");
    }
    CandumpRecord record;
    const Status status =
        ParseCandumpLine(line, path + ":" + std::to_string(number), &record);
    if (!status.ok()) return status;
    records->push_back(std::move(record));
  }
  if (in.bad()) return Status::Error(path + ": read error");
  return Status::Ok();
}

}  // namespace kcrig
