// Errors cross module boundaries as values, never as exceptions (Ceres style).
#ifndef KCRIG_RT_CORE_STATUS_H_
#define KCRIG_RT_CORE_STATUS_H_

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

#endif  // KCRIG_RT_CORE_STATUS_H_
