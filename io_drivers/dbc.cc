#include "io_drivers/dbc.h"

#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <set>
#include <sstream>

namespace kcrig {
namespace {

struct Token {
  enum Kind { kIdentifier, kNumber, kString, kPunct, kEnd };
  Kind kind = kEnd;
  std::string text;
  int line = 0;
  bool line_start = false;  // first token on its line
  bool indented = false;    // ... and the line starts with white space
};

bool IsIdentifierStart(char c) {
  return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || c == '_';
}
bool IsDigit(char c) { return c >= '0' && c <= '9'; }

class Lexer {
 public:
  Lexer(std::string_view text, const std::string& source)
      : text_(text), source_(source) {}

  Status Tokenize(std::vector<Token>* tokens) {
    bool line_start = true, indented = false;
    size_t i = 0;
    while (i < text_.size()) {
      const char c = text_[i];
      if (c == '\n') {
        ++line_, ++i;
        line_start = true;
        indented = i < text_.size() && (text_[i] == ' ' || text_[i] == '\t');
        continue;
      }
      if (c == ' ' || c == '\t' || c == '\r') {
        ++i;
        continue;
      }
      if (c == '/' && i + 1 < text_.size() && text_[i + 1] == '/') {
        while (i < text_.size() && text_[i] != '\n') ++i;
        continue;
      }
      Token token;
      token.line = line_;
      token.line_start = line_start;
      token.indented = line_start && indented;
      line_start = false;
      const size_t begin = i;
      const bool signed_number =
          (c == '-' || c == '+') && i + 1 < text_.size() &&
          (IsDigit(text_[i + 1]) || text_[i + 1] == '.') &&
          (i == 0 ||
           !(IsDigit(text_[i - 1]) || IsIdentifierStart(text_[i - 1])));
      if (c == '"') {
        ++i;
        std::string value;
        while (i < text_.size() && text_[i] != '"') {
          if (text_[i] == '\\' && i + 1 < text_.size()) ++i;
          if (text_[i] == '\n') ++line_;
          value += text_[i++];
        }
        if (i >= text_.size()) {
          return Status::Error(source_ + ":" + std::to_string(token.line) +
                               ": string not terminated");
        }
        ++i;
        token.kind = Token::kString;
        token.text = std::move(value);
      } else if (IsDigit(c) || signed_number ||
                 (c == '.' && i + 1 < text_.size() && IsDigit(text_[i + 1]))) {
        if (signed_number) ++i;
        while (i < text_.size() && (IsDigit(text_[i]) || text_[i] == '.')) ++i;
        if (i < text_.size() && (text_[i] == 'e' || text_[i] == 'E')) {
          size_t j = i + 1;
          if (j < text_.size() && (text_[j] == '+' || text_[j] == '-')) ++j;
          if (j < text_.size() && IsDigit(text_[j])) {
            i = j;
            while (i < text_.size() && IsDigit(text_[i])) ++i;
          }
        }
        token.kind = Token::kNumber;
        token.text = std::string(text_.substr(begin, i - begin));
      } else if (IsIdentifierStart(c)) {
        while (i < text_.size() &&
               (IsIdentifierStart(text_[i]) || IsDigit(text_[i]))) {
          ++i;
        }
        token.kind = Token::kIdentifier;
        token.text = std::string(text_.substr(begin, i - begin));
      } else {
        ++i;
        token.kind = Token::kPunct;
        token.text = std::string(1, c);
      }
      tokens->push_back(std::move(token));
    }
    Token end;
    end.line = line_;
    end.line_start = true;
    tokens->push_back(end);
    return Status::Ok();
  }

 private:
  std::string_view text_;
  const std::string& source_;
  int line_ = 1;
};

// Keywords that start a statement on their own line; a statement read over
// up to its ';' must not run into one of these.
bool IsSectionKeyword(const std::string& word) {
  return word == "BO_" || word == "SG_" || word == "BU_" || word == "BS_" ||
         word == "VERSION" || word == "NS_";
}

class Parser {
 public:
  Parser(const std::vector<Token>& tokens, const std::string& source)
      : tokens_(tokens), source_(source) {}

  Status Parse(Dbc* dbc) {
    while (Peek().kind != Token::kEnd) {
      const Token& token = Next();
      if (token.kind != Token::kIdentifier) {
        return ErrorAt(token, "expected a keyword, found '" + token.text + "'");
      }
      Status status;
      if (token.text == "VERSION") {
        status = ExpectString(&dbc->version);
      } else if (token.text == "NS_") {
        status = SkipNewSymbols();
      } else if (token.text == "BS_") {
        SkipRestOfLine();
      } else if (token.text == "BU_") {
        status = ParseNodes(dbc);
      } else if (token.text == "BO_") {
        status = ParseMessage(token, dbc);
      } else if (token.text == "SG_") {
        if (dbc->messages.empty() && !skip_signals_) {
          return ErrorAt(token, "SG_ before any BO_");
        }
        DbcMessage independent;  // signals of no message: read over
        status = ParseSignal(
            token, skip_signals_ ? &independent : &dbc->messages.back());
      } else if (token.text == "SIG_VALTYPE_") {
        status = RefuseFloatSignal(token);
      } else {
        status = SkipStatement(token);
      }
      if (!status.ok()) return status;
    }
    return Validate(*dbc);
  }

 private:
  const Token& Peek() const { return tokens_[position_]; }
  const Token& Next() {
    const Token& token = tokens_[position_];
    if (token.kind != Token::kEnd) ++position_;
    return token;
  }

  Status ErrorAt(const Token& token, const std::string& what) const {
    return Status::Error(source_ + ":" + std::to_string(token.line) + ": " +
                         what);
  }

  Status Expect(const char* punct) {
    const Token& token = Next();
    if (token.kind != Token::kPunct || token.text != punct) {
      return ErrorAt(token, std::string("expected '") + punct + "', found '" +
                                token.text + "'");
    }
    return Status::Ok();
  }

  Status ExpectString(std::string* value) {
    const Token& token = Next();
    if (token.kind != Token::kString) {
      return ErrorAt(token, "expected a quoted string");
    }
    *value = token.text;
    return Status::Ok();
  }

  Status ExpectIdentifier(const char* what, std::string* value) {
    const Token& token = Next();
    if (token.kind != Token::kIdentifier) {
      return ErrorAt(token, std::string("expected ") + what + ", found '" +
                                token.text + "'");
    }
    *value = token.text;
    return Status::Ok();
  }

  Status ExpectUnsigned(const char* what, std::uint64_t max,
                        std::uint64_t* value) {
    const Token& token = Next();
    const char* begin = token.text.data();
    const char* end = begin + token.text.size();
    std::uint64_t parsed = 0;
    const auto [ptr, error] = std::from_chars(begin, end, parsed);
    if (token.kind != Token::kNumber || error != std::errc() || ptr != end ||
        parsed > max) {
      return ErrorAt(token, std::string(what) + " '" + token.text +
                                "' is not an integer in 0.." +
                                std::to_string(max));
    }
    *value = parsed;
    return Status::Ok();
  }

  Status ExpectDouble(const char* what, double* value) {
    const Token& token = Next();
    char* end = nullptr;
    const double parsed = std::strtod(token.text.c_str(), &end);
    if (token.kind != Token::kNumber ||
        end != token.text.c_str() + token.text.size() ||
        !std::isfinite(parsed)) {
      return ErrorAt(token, std::string(what) + " '" + token.text +
                                "' is not a finite number");
    }
    *value = parsed;
    return Status::Ok();
  }

  Status SkipNewSymbols() {
    Status status = Expect(":");
    if (!status.ok()) return status;
    // The symbol list is the indented lines after "NS_ :".
    while (Peek().kind == Token::kIdentifier &&
           (!Peek().line_start || Peek().indented)) {
      Next();
    }
    return Status::Ok();
  }

  void SkipRestOfLine() {
    while (Peek().kind != Token::kEnd && !Peek().line_start) Next();
  }

  Status ParseNodes(Dbc* dbc) {
    Status status = Expect(":");
    if (!status.ok()) return status;
    while (Peek().kind == Token::kIdentifier && !Peek().line_start) {
      dbc->nodes.push_back(Next().text);
    }
    return Status::Ok();
  }

  Status ParseMessage(const Token& keyword, Dbc* dbc) {
    DbcMessage message;
    std::uint64_t id = 0, dlc = 0;
    Status status = ExpectUnsigned("message id", 0xFFFFFFFFu, &id);
    if (status.ok()) status = ExpectIdentifier("a message name", &message.name);
    if (status.ok()) status = Expect(":");
    if (status.ok()) status = ExpectUnsigned("DLC", 64, &dlc);
    if (status.ok()) {
      status = ExpectIdentifier("the sending node", &message.sender);
    }
    if (!status.ok()) return status;
    message.extended = (id & 0x80000000u) != 0;
    message.id = static_cast<std::uint32_t>(id & 0x7FFFFFFFu);
    message.dlc = static_cast<int>(dlc);
    // The pseudo-message that holds signals of no message (id 0xC0000000,
    // "VECTOR__INDEPENDENT_SIG_MSG") carries nothing on the bus.
    if (message.id == 0x40000000u) {
      skip_signals_ = true;
      return Status::Ok();
    }
    skip_signals_ = false;
    if (message.extended ? message.id > 0x1FFFFFFFu : message.id > 0x7FFu) {
      return ErrorAt(keyword, "message " + message.name + ": id " +
                                  std::to_string(id) + " is out of range");
    }
    if (message.dlc > 8) {
      return ErrorAt(keyword, "message " + message.name + ": DLC " +
                                  std::to_string(message.dlc) +
                                  " (CAN FD) is not supported, classic CAN "
                                  "frames carry at most 8 bytes");
    }
    dbc->messages.push_back(std::move(message));
    message_lines_.push_back(keyword.line);
    return Status::Ok();
  }

  Status ParseSignal(const Token& keyword, DbcMessage* message) {
    DbcSignal signal;
    Status status = ExpectIdentifier("a signal name", &signal.name);
    if (!status.ok()) return status;
    if (Peek().kind == Token::kIdentifier) {
      return ErrorAt(Peek(), "signal " + signal.name +
                                 ": multiplexed signals are not supported");
    }
    std::uint64_t start = 0, length = 0, order = 0;
    status = Expect(":");
    if (status.ok()) status = ExpectUnsigned("start bit", 511, &start);
    if (status.ok()) status = Expect("|");
    if (status.ok()) status = ExpectUnsigned("length", 512, &length);
    if (status.ok()) status = Expect("@");
    if (status.ok()) status = ExpectUnsigned("byte order", 1, &order);
    if (!status.ok()) return status;
    const Token& sign = Next();
    if (sign.kind != Token::kPunct || (sign.text != "+" && sign.text != "-")) {
      return ErrorAt(sign, "signal " + signal.name +
                               ": expected '+' or '-' after the byte order");
    }
    status = Expect("(");
    if (status.ok()) status = ExpectDouble("factor", &signal.factor);
    if (status.ok()) status = Expect(",");
    if (status.ok()) status = ExpectDouble("offset", &signal.offset);
    if (status.ok()) status = Expect(")");
    if (status.ok()) status = Expect("[");
    if (status.ok()) status = ExpectDouble("minimum", &signal.minimum);
    if (status.ok()) status = Expect("|");
    if (status.ok()) status = ExpectDouble("maximum", &signal.maximum);
    if (status.ok()) status = Expect("]");
    if (status.ok()) status = ExpectString(&signal.unit);
    if (!status.ok()) return status;
    while (Peek().kind == Token::kIdentifier && !Peek().line_start) {
      signal.receivers.push_back(Next().text);
      if (Peek().kind == Token::kPunct && Peek().text == "," &&
          !Peek().line_start) {
        Next();
      }
    }
    signal.start_bit = static_cast<int>(start);
    signal.length = static_cast<int>(length);
    signal.little_endian = order == 1;
    signal.is_signed = sign.text == "-";
    if (skip_signals_) return Status::Ok();
    status = Layout(keyword, *message, &signal);
    if (!status.ok()) return status;
    message->signals.push_back(std::move(signal));
    return Status::Ok();
  }

  // Where the signal's bits are, and the range the codec can hold.
  Status Layout(const Token& keyword, const DbcMessage& message,
                DbcSignal* s) const {
    const std::string what = "signal " + message.name + "." + s->name + ": ";
    if (s->length < 1 || s->length > 64) {
      return ErrorAt(keyword, what + "length " + std::to_string(s->length) +
                                  " is not in 1..64");
    }
    if (s->factor == 0) return ErrorAt(keyword, what + "factor is zero");
    if (s->minimum > s->maximum) {
      return ErrorAt(keyword, what + "minimum is above maximum");
    }
    const int frame_bits = 8 * message.dlc;
    if (s->little_endian) {
      if (s->start_bit + s->length > frame_bits) {
        return ErrorAt(keyword,
                       what + "bits " + std::to_string(s->start_bit) + ".." +
                           std::to_string(s->start_bit + s->length - 1) +
                           " do not fit in " + std::to_string(message.dlc) +
                           " bytes");
      }
      s->shift = s->start_bit;
    } else {
      // Motorola: the start bit is the MSB; count bits from the frame's
      // first MSB (big-endian order) to find the LSB.
      const int msb = (s->start_bit / 8) * 8 + (7 - s->start_bit % 8);
      const int lsb = msb + s->length - 1;
      if (lsb >= frame_bits) {
        return ErrorAt(keyword, what + "Motorola signal from bit " +
                                    std::to_string(s->start_bit) +
                                    " does not fit in " +
                                    std::to_string(message.dlc) + " bytes");
      }
      s->shift = 63 - lsb;
    }
    s->mask = s->length == 64 ? ~std::uint64_t{0}
                              : (std::uint64_t{1} << s->length) - 1;
    const double raw_low = s->is_signed ? -std::ldexp(1.0, s->length - 1) : 0.0;
    const double raw_high = s->is_signed ? std::ldexp(1.0, s->length - 1) - 1
                                         : std::ldexp(1.0, s->length) - 1;
    double low = raw_low * s->factor + s->offset;
    double high = raw_high * s->factor + s->offset;
    if (low > high) std::swap(low, high);
    if (s->minimum != 0 || s->maximum != 0) {
      low = std::max(low, s->minimum);
      high = std::min(high, s->maximum);
      if (low > high) {
        return ErrorAt(keyword, what + "[minimum|maximum] lies outside what " +
                                    std::to_string(s->length) +
                                    " bits can hold");
      }
    }
    s->lowest = low;
    s->highest = high;
    return Status::Ok();
  }

  Status RefuseFloatSignal(const Token& keyword) {
    std::uint64_t id = 0;
    std::string name;
    Status status = ExpectUnsigned("message id", 0xFFFFFFFFu, &id);
    if (status.ok()) status = ExpectIdentifier("a signal name", &name);
    if (!status.ok()) return status;
    return ErrorAt(keyword, "signal " + name +
                                ": IEEE float signals (SIG_VALTYPE_) are not "
                                "supported");
  }

  // Annotations (CM_, BA_, VAL_, ...): read over up to their ';'.
  Status SkipStatement(const Token& keyword) {
    while (true) {
      const Token& token = Peek();
      if (token.kind == Token::kEnd ||
          (token.line_start && token.kind == Token::kIdentifier &&
           IsSectionKeyword(token.text))) {
        return ErrorAt(keyword,
                       keyword.text + " statement is not ended by ';'");
      }
      Next();
      if (token.kind == Token::kPunct && token.text == ";") {
        return Status::Ok();
      }
    }
  }

  Status Validate(const Dbc& dbc) const {
    std::set<std::pair<std::uint32_t, bool>> ids;
    std::set<std::string> names;
    for (size_t m = 0; m < dbc.messages.size(); ++m) {
      const DbcMessage& message = dbc.messages[m];
      const std::string where = source_ + ":" +
                                std::to_string(message_lines_[m]) +
                                ": message " + message.name;
      if (!ids.insert({message.id, message.extended}).second) {
        return Status::Error(where + ": id " + std::to_string(message.id) +
                             " is defined twice");
      }
      if (!names.insert(message.name).second) {
        return Status::Error(where + ": name is defined twice");
      }
      std::set<std::string> signal_names;
      std::uint64_t used = 0;  // bits taken, numbered as in an Intel word
      for (const DbcSignal& s : message.signals) {
        if (!signal_names.insert(s.name).second) {
          return Status::Error(where + ": signal " + s.name +
                               " is defined twice");
        }
        // Overlap, in one common bit numbering (the little-endian word's).
        std::uint64_t bits = 0;
        for (int k = 0; k < s.length; ++k) {
          const int word_bit = s.shift + k;
          const int bit = s.little_endian
                              ? word_bit
                              : (7 - word_bit / 8) * 8 + word_bit % 8;
          bits |= std::uint64_t{1} << bit;
        }
        if (used & bits) {
          return Status::Error(where + ": signal " + s.name +
                               " overlaps another signal");
        }
        used |= bits;
      }
    }
    return Status::Ok();
  }

  const std::vector<Token>& tokens_;
  const std::string& source_;
  size_t position_ = 0;
  bool skip_signals_ = false;
  std::vector<int> message_lines_;
};

// The frame's first eight bytes as one integer, little- or big-endian.
std::uint64_t ReadWord(const std::uint8_t* data, bool little_endian) {
  std::uint64_t word;
  std::memcpy(&word, data, 8);
  const bool swap =
      little_endian != (std::endian::native == std::endian::little);
  return swap ? __builtin_bswap64(word) : word;
}

void WriteWord(std::uint64_t word, bool little_endian, std::uint8_t* data) {
  const bool swap =
      little_endian != (std::endian::native == std::endian::little);
  if (swap) word = __builtin_bswap64(word);
  std::memcpy(data, &word, 8);
}

// Round half to even without a libm call (the codec runs every cycle).
double RoundToInteger(double x) {
  constexpr double kShift = 0x1.8p52;
  if (!(std::abs(x) < 0x1p51)) return x;  // integral already (or NaN)
  return x >= 0 ? (x + kShift) - kShift : (x - kShift) + kShift;
}

}  // namespace

const DbcSignal* DbcMessage::FindSignal(std::string_view signal_name) const {
  for (const DbcSignal& s : signals) {
    if (s.name == signal_name) return &s;
  }
  return nullptr;
}

const DbcMessage* Dbc::FindMessage(std::string_view message_name) const {
  for (const DbcMessage& m : messages) {
    if (m.name == message_name) return &m;
  }
  return nullptr;
}

const DbcMessage* Dbc::FindMessage(std::uint32_t id, bool extended) const {
  for (const DbcMessage& m : messages) {
    if (m.id == id && m.extended == extended) return &m;
  }
  return nullptr;
}

Status ParseDbc(std::string_view text, const std::string& source, Dbc* dbc) {
  *dbc = Dbc();
  std::vector<Token> tokens;
  Status status = Lexer(text, source).Tokenize(&tokens);
  if (!status.ok()) return status;
  return Parser(tokens, source).Parse(dbc);
}

Status LoadDbc(const std::string& path, Dbc* dbc) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return Status::Error(path + ": cannot open the DBC file");
  constexpr std::streamsize kMaxSize = 16 << 20;
  std::string text;
  text.resize(kMaxSize + 1);
  in.read(text.data(), kMaxSize + 1);
  if (in.bad()) return Status::Error(path + ": cannot read the DBC file");
  if (in.gcount() > kMaxSize) {
    return Status::Error(path + ": larger than 16 MiB, not a DBC file");
  }
  text.resize(static_cast<size_t>(in.gcount()));
  return ParseDbc(text, path, dbc);
}

double DecodeSignal(const DbcSignal& signal, const std::uint8_t* data,
                    bool* out_of_range) {
  const std::uint64_t raw =
      (ReadWord(data, signal.little_endian) >> signal.shift) & signal.mask;
  double value;
  if (signal.is_signed && signal.length < 64 &&
      (raw >> (signal.length - 1)) != 0) {
    value = static_cast<double>(static_cast<std::int64_t>(raw | ~signal.mask));
  } else if (signal.is_signed) {
    value = static_cast<double>(static_cast<std::int64_t>(raw));
  } else {
    value = static_cast<double>(raw);
  }
  value = value * signal.factor + signal.offset;
  if (value < signal.lowest || value > signal.highest) {
    *out_of_range = true;
    value = std::clamp(value, signal.lowest, signal.highest);
  }
  return value;
}

void EncodeSignal(const DbcSignal& signal, double value, std::uint8_t* data,
                  bool* out_of_range) {
  if (std::isnan(value)) {
    *out_of_range = true;
    value = std::clamp(0.0, signal.lowest, signal.highest);
  } else if (value < signal.lowest || value > signal.highest) {
    *out_of_range = true;
    value = std::clamp(value, signal.lowest, signal.highest);
  }
  double raw = RoundToInteger((value - signal.offset) / signal.factor);
  // Rounding may step past the range's last raw value: step back inside.
  const double back = raw * signal.factor + signal.offset;
  if (back > signal.highest + 1e-12 * std::abs(signal.highest)) {
    raw -= signal.factor > 0 ? 1 : -1;
  } else if (back < signal.lowest - 1e-12 * std::abs(signal.lowest)) {
    raw += signal.factor > 0 ? 1 : -1;
  }
  // The raw range; for 64-bit signals its last double below 2^63 / 2^64.
  std::uint64_t bits;
  if (signal.is_signed) {
    const double limit = std::ldexp(1.0, signal.length - 1);
    raw = std::clamp(raw, -limit,
                     std::min(limit - 1, std::nextafter(limit, 0.0)));
    bits = static_cast<std::uint64_t>(static_cast<std::int64_t>(raw));
  } else {
    const double limit = std::ldexp(1.0, signal.length);
    raw = std::clamp(raw, 0.0, std::min(limit - 1, std::nextafter(limit, 0.0)));
    bits = static_cast<std::uint64_t>(raw);
  }
  std::uint64_t word = ReadWord(data, signal.little_endian);
  word &= ~(signal.mask << signal.shift);
  word |= (bits & signal.mask) << signal.shift;
  WriteWord(word, signal.little_endian, data);
}

}  // namespace kcrig
