// Errors cross module boundaries as values, never as exceptions (Ceres style).
#ifndef KCRIG_BASE_STATUS_H_
#define KCRIG_BASE_STATUS_H_

#include <string>
#include <utility>

namespace kcrig {

class Status {
 public:
  static Status Ok() { return Status(); }
  static Status Error(std::string message) {
    Status status;
    status.ok_ = false;
    status.message_ = std::move(message);
    return status;
  }

  bool ok() const { return ok_; }
  // One line, naming the file, line or field at fault.
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
