// Values as bytes and back, exactly (doubles bit for bit, NaN and infinity
// included): what a batch job's result is while it travels between MPI
// ranks (base/batch_runner.h). Native byte order: the ranks of one job run
// one build on one kind of machine.
#ifndef KCRIG_BASE_BYTE_CODEC_H_
#define KCRIG_BASE_BYTE_CODEC_H_

#include <cstdint>
#include <cstring>
#include <string>
#include <type_traits>

#include "Eigen/Core"

namespace kcrig {

class ByteWriter {
 public:
  template <typename T, typename = std::enable_if_t<std::is_arithmetic_v<T>>>
  void Put(T value) {
    bytes_.append(reinterpret_cast<const char*>(&value), sizeof(value));
  }
  void Put(const std::string& text) {
    Put<std::uint64_t>(text.size());
    bytes_ += text;
  }
  template <typename Derived>
  void PutMatrix(const Eigen::DenseBase<Derived>& m) {
    Put<std::int64_t>(m.rows());
    Put<std::int64_t>(m.cols());
    for (Eigen::Index j = 0; j < m.cols(); ++j) {
      for (Eigen::Index i = 0; i < m.rows(); ++i) Put<double>(m(i, j));
    }
  }
  const std::string& bytes() const { return bytes_; }

 private:
  std::string bytes_;
};

// Reads what a ByteWriter wrote, in the same order; a read past the end
// (or a corrupt length) leaves ok() false and the value untouched.
class ByteReader {
 public:
  explicit ByteReader(const std::string& bytes) : bytes_(bytes) {}
  template <typename T, typename = std::enable_if_t<std::is_arithmetic_v<T>>>
  void Get(T* value) {
    if (!Have(sizeof(T))) return;
    std::memcpy(value, bytes_.data() + at_, sizeof(T));
    at_ += sizeof(T);
  }
  void Get(std::string* text) {
    std::uint64_t size = 0;
    Get(&size);
    if (!Have(size)) return;
    text->assign(bytes_, at_, size);
    at_ += size;
  }
  void GetMatrix(Eigen::MatrixXd* m) {
    std::int64_t rows = 0, cols = 0;
    Get(&rows);
    Get(&cols);
    constexpr std::int64_t kMaxSide = 1 << 20;  // no overflow below
    if (rows < 0 || cols < 0 || rows > kMaxSide || cols > kMaxSide ||
        !Have(static_cast<std::uint64_t>(rows) * cols * sizeof(double))) {
      ok_ = false;
      return;
    }
    m->resize(rows, cols);
    for (Eigen::Index j = 0; j < cols; ++j) {
      for (Eigen::Index i = 0; i < rows; ++i) Get(&(*m)(i, j));
    }
  }
  // What was read is not what the writer wrote (a length out of reason).
  void Fail() { ok_ = false; }
  // Every read succeeded and every byte was read.
  bool ok() const { return ok_ && at_ == bytes_.size(); }

 private:
  bool Have(std::uint64_t n) {
    ok_ = ok_ && n <= bytes_.size() - at_;
    return ok_;
  }
  const std::string& bytes_;
  size_t at_ = 0;
  bool ok_ = true;
};

}  // namespace kcrig

#endif  // KCRIG_BASE_BYTE_CODEC_H_
