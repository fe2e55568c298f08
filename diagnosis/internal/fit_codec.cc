#include "diagnosis/internal/fit_codec.h"

#include <cstdint>

#include "base/byte_codec.h"

namespace kcrig {
namespace {

// The two directions of the codec share one description of each type
// (Visit): an archive is called on every field in the same order, the
// writer appending it, the reader filling it.
class Writer {
 public:
  template <typename T>
  void operator()(T& x) {
    out.Put(x);  // a number or a std::string
  }
  void operator()(Eigen::MatrixXd& x) { out.PutMatrix(x); }
  void operator()(Eigen::VectorXd& x) { out.PutMatrix(x); }
  void operator()(Vec6<double>& x) { out.PutMatrix(x); }
  template <typename T>
  void operator()(std::vector<T>& x) {
    std::uint64_t size = x.size();
    out.Put(size);
    for (auto&& item : x) Element(item);
  }
  template <typename T>
  void Element(T& x);
  void Element(std::vector<bool>::reference x) {
    bool b = x;
    out.Put<std::uint8_t>(b);
  }
  ByteWriter out;
};

class Reader {
 public:
  explicit Reader(const std::string& bytes) : in(bytes) {}
  template <typename T>
  void operator()(T& x) {
    in.Get(&x);
  }
  void operator()(Eigen::MatrixXd& x) { in.GetMatrix(&x); }
  void operator()(Eigen::VectorXd& x) {
    Eigen::MatrixXd m;
    in.GetMatrix(&m);
    if (m.cols() != 1) return in.Fail();
    x = m.col(0);
  }
  void operator()(Vec6<double>& x) {
    Eigen::MatrixXd m;
    in.GetMatrix(&m);
    if (m.rows() != 6 || m.cols() != 1) return in.Fail();
    x = m.col(0);
  }
  template <typename T>
  void operator()(std::vector<T>& x) {
    std::uint64_t size = 0;
    in.Get(&size);
    if (size > (1u << 24)) return in.Fail();
    x.clear();
    x.resize(size);  // every element is read below
    for (auto&& item : x) Element(item);
  }
  template <typename T>
  void Element(T& x);
  void Element(std::vector<bool>::reference x) {
    std::uint8_t b = 0;
    in.Get(&b);
    x = b != 0;
  }
  ByteReader in;
};

template <typename A>
void Visit(A& a, ParameterEstimate& p) {
  a(p.name);
  a(p.unit);
  a(p.nominal);
  a(p.initial);
  a(p.value);
  a(p.standard_error);
  a(p.ci95_low);
  a(p.ci95_high);
  a(p.log10_inverse_information);
  a(p.identifiable);
  a(p.at_bound);
  a(p.discretisation_bias);
}

template <typename A>
void Visit(A& a, ChannelAdequacy& c) {
  a(c.used);
  a(c.score);
  a(c.whiteness_p);
  a(c.samples);
  a(c.discretisation);
}

template <typename A>
void Visit(A& a, Adequacy& q) {
  a(q.assessed);
  a(q.chi_square);
  a(q.dof);
  a(q.p_value);
  a(q.score);
  a(q.whiteness_p);
  for (ChannelAdequacy& c : q.channels) Visit(a, c);
  a(q.adequate);
  a(q.reason);
  a(q.discretisation);
  a(q.continuous_limit);
}

template <typename A>
void Visit(A& a, LogInitialState& s) {
  bool has_tare = s.tare.has_value();
  a(has_tare);
  if (has_tare && !s.tare) s.tare.emplace();  // reading
  if (has_tare) {
    a(s.tare->mean);
    a(s.tare->at_start);
  }
  a(s.from_first_row_pose);
  a(s.dahl_forces);
}

template <typename A>
void Visit(A& a, EstimationResult& r) {
  a(r.parameters);
  a(r.covariance);
  a(r.correlation);
  a(r.singular_values);
  a(r.information);
  a(r.condition_number);
  a(r.rank);
  a(r.ill_conditioned);
  a(r.unidentifiable_combinations);
  a(r.dependent_parameters);
  a(r.residual_rms);
  a(r.channel_used);
  a(r.num_residuals);
  a(r.memory_rows);
  a(r.initial_states);
  a(r.cost);
  a(r.sigma_hat);
  a(r.residual_correlation);
  a(r.interval_widening);
  Visit(a, r.adequacy);
  a(r.iterations);
  a(r.seconds);
  a(r.integrator_step);
  a(r.converged);
  a(r.termination);
}

template <typename A>
void Visit(A& a, EffectFit& f) {
  a(f.model);
  Visit(a, f.result);
  a(f.values);
}

template <typename A>
void Visit(A& a, Status& status) {
  bool ok = status.ok();
  std::string message = status.message();
  a(ok);
  a(message);
  status = ok ? Status::Ok() : Status::Error(message);
}

// Elements of vectors: structs by Visit, the rest as fields.
template <typename T>
void Writer::Element(T& x) {
  if constexpr (std::is_same_v<T, ParameterEstimate> ||
                std::is_same_v<T, LogInitialState>) {
    Visit(*this, x);
  } else {
    (*this)(x);
  }
}
template <typename T>
void Reader::Element(T& x) {
  if constexpr (std::is_same_v<T, ParameterEstimate> ||
                std::is_same_v<T, LogInitialState>) {
    Visit(*this, x);
  } else {
    (*this)(x);
  }
}

}  // namespace

// Visit takes non-const references (one description for both directions):
// the encoders work on copies.
std::string EncodeFit(const Status& status, const EffectFit& fit) {
  Writer writer;
  Status s = status;
  EffectFit f = fit;
  Visit(writer, s);
  Visit(writer, f);
  return writer.out.bytes();
}

bool DecodeFit(const std::string& bytes, Status* status, EffectFit* fit) {
  Reader reader(bytes);
  Visit(reader, *status);
  Visit(reader, *fit);
  return reader.in.ok();
}

std::string EncodeResiduals(const Status& status,
                            const std::vector<Vec6<double>>& residuals) {
  Writer writer;
  Status s = status;
  std::vector<Vec6<double>> r = residuals;
  Visit(writer, s);
  writer(r);
  return writer.out.bytes();
}

bool DecodeResiduals(const std::string& bytes, Status* status,
                     std::vector<Vec6<double>>* residuals) {
  Reader reader(bytes);
  Visit(reader, *status);
  reader(*residuals);
  return reader.in.ok();
}

}  // namespace kcrig
