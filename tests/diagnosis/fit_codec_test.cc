// A fit computed on another MPI rank arrives bit for bit (NaN, infinity,
// matrices, texts and flags included); a truncated or padded result is
// refused.
#include "diagnosis/internal/fit_codec.h"

#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "gtest/gtest.h"

namespace kcrig {
namespace {

EffectFit SomeFit() {
  EffectFit fit;
  fit.model = "hysteresis@bushing:V2";
  ParameterEstimate p;
  p.name = "c_O1";
  p.unit = "N/m";
  p.value = 4.1e6;
  p.standard_error = std::numeric_limits<double>::infinity();
  p.ci95_low = std::numeric_limits<double>::quiet_NaN();
  p.identifiable = false;
  p.at_bound = true;
  fit.result.parameters = {p, p};
  fit.result.covariance = Eigen::MatrixXd::Random(3, 2);
  fit.result.singular_values = Eigen::VectorXd::Random(4);
  fit.result.information = Eigen::MatrixXd::Identity(2, 2) * 1e-300;
  fit.result.unidentifiable_combinations = {"0.707 c_V1 - 0.707 c_V2", ""};
  fit.result.residual_rms << 1e-5, 2e-5, 3e-5, 1e-4, 2e-4, -0.0;
  fit.result.channel_used = {true, false, true, true, false, true};
  fit.result.adequacy.channels[3].samples = 123456789012L;
  fit.result.adequacy.reason = "Ljung-Box p 1e-9 on z";
  fit.result.sigma_hat = 1.2345678901234567;
  fit.result.correlation = Eigen::MatrixXd::Random(2, 2);
  fit.result.condition_number = 3.5e7;
  fit.result.rank = 4;
  fit.result.ill_conditioned = true;
  fit.result.dependent_parameters = {"c_P"};
  fit.result.num_residuals = 36006;
  fit.result.memory_rows = {1200, 0};
  fit.result.initial_states.resize(2);
  TarePose tare;
  tare.mean << 1e-5, -2e-5, 3e-6, 1e-4, 0, -1e-3;
  tare.at_start << 2e-5, -1e-5, 0, 1e-4, 0, 1e-3;
  fit.result.initial_states[0].tare = tare;
  fit.result.initial_states[0].dahl_forces = {0, -305.5, 0, 12.25, 0};
  fit.result.initial_states[1].from_first_row_pose = true;
  fit.result.cost = 18003.25;
  fit.result.iterations = 17;
  fit.result.seconds = 0.25;
  fit.result.integrator_step = 1e-3;
  Adequacy& a = fit.result.adequacy;
  a.assessed = true;
  a.chi_square = 40001.5;
  a.dof = 35999;
  a.p_value = 1e-30;
  a.score = 1.11;
  a.whiteness_p = 2e-9;
  a.channels[5] = {true, 1.5, 0.25, 6001, 0.125};
  a.adequate = false;
  a.discretisation = 0.02;
  a.continuous_limit = true;
  fit.result.converged = true;
  fit.result.termination = "function tolerance";
  fit.values = {4.1e6, std::nextafter(1.0, 2.0)};
  return fit;
}

bool SameBits(double a, double b) {
  return std::memcmp(&a, &b, sizeof(double)) == 0;
}

TEST(FitCodecTest, AFitAndItsStatusArriveBitForBit) {
  const EffectFit fit = SomeFit();
  const std::string bytes = EncodeFit(Status::Error("no fit: diverged"), fit);
  Status status;
  EffectFit back;
  ASSERT_TRUE(DecodeFit(bytes, &status, &back));
  EXPECT_FALSE(status.ok());
  EXPECT_EQ(status.message(), "no fit: diverged");
  EXPECT_EQ(back.model, fit.model);
  ASSERT_EQ(back.result.parameters.size(), 2u);
  EXPECT_EQ(back.result.parameters[1].unit, "N/m");
  EXPECT_TRUE(std::isinf(back.result.parameters[1].standard_error));
  EXPECT_TRUE(SameBits(back.result.parameters[1].ci95_low,
                       fit.result.parameters[1].ci95_low));
  EXPECT_FALSE(back.result.parameters[1].identifiable);
  EXPECT_TRUE(back.result.parameters[1].at_bound);
  EXPECT_EQ(back.result.covariance, fit.result.covariance);
  EXPECT_EQ(back.result.singular_values, fit.result.singular_values);
  EXPECT_EQ(back.result.information, fit.result.information);
  EXPECT_EQ(back.result.unidentifiable_combinations,
            fit.result.unidentifiable_combinations);
  for (int k = 0; k < 6; ++k) {
    EXPECT_TRUE(
        SameBits(back.result.residual_rms(k), fit.result.residual_rms(k)));
  }
  EXPECT_EQ(back.result.channel_used, fit.result.channel_used);
  EXPECT_EQ(back.result.adequacy.channels[3].samples, 123456789012L);
  EXPECT_EQ(back.result.adequacy.reason, fit.result.adequacy.reason);
  EXPECT_TRUE(SameBits(back.result.sigma_hat, fit.result.sigma_hat));
  EXPECT_TRUE(back.result.converged);
  EXPECT_EQ(back.result.termination, fit.result.termination);
  EXPECT_EQ(back.result.correlation, fit.result.correlation);
  EXPECT_EQ(back.result.condition_number, 3.5e7);
  EXPECT_EQ(back.result.rank, 4);
  EXPECT_TRUE(back.result.ill_conditioned);
  EXPECT_EQ(back.result.dependent_parameters, fit.result.dependent_parameters);
  EXPECT_EQ(back.result.num_residuals, 36006);
  EXPECT_EQ(back.result.memory_rows, std::vector<int>({1200, 0}));
  ASSERT_EQ(back.result.initial_states.size(), 2u);
  ASSERT_TRUE(back.result.initial_states[0].tare.has_value());
  EXPECT_EQ(back.result.initial_states[0].tare->mean,
            fit.result.initial_states[0].tare->mean);
  EXPECT_EQ(back.result.initial_states[0].tare->at_start,
            fit.result.initial_states[0].tare->at_start);
  EXPECT_FALSE(back.result.initial_states[0].from_first_row_pose);
  EXPECT_EQ(back.result.initial_states[0].dahl_forces,
            fit.result.initial_states[0].dahl_forces);
  EXPECT_FALSE(back.result.initial_states[1].tare.has_value());
  EXPECT_TRUE(back.result.initial_states[1].from_first_row_pose);
  EXPECT_TRUE(back.result.initial_states[1].dahl_forces.empty());
  EXPECT_EQ(back.result.cost, 18003.25);
  EXPECT_EQ(back.result.iterations, 17);
  EXPECT_EQ(back.result.seconds, 0.25);
  EXPECT_EQ(back.result.integrator_step, 1e-3);
  const Adequacy& a = back.result.adequacy;
  EXPECT_TRUE(a.assessed);
  EXPECT_EQ(a.chi_square, 40001.5);
  EXPECT_EQ(a.dof, 35999);
  EXPECT_EQ(a.p_value, 1e-30);
  EXPECT_EQ(a.score, 1.11);
  EXPECT_EQ(a.whiteness_p, 2e-9);
  EXPECT_TRUE(a.channels[5].used);
  EXPECT_EQ(a.channels[5].score, 1.5);
  EXPECT_EQ(a.channels[5].whiteness_p, 0.25);
  EXPECT_EQ(a.channels[5].samples, 6001);
  EXPECT_EQ(a.channels[5].discretisation, 0.125);
  EXPECT_FALSE(a.adequate);
  EXPECT_EQ(a.discretisation, 0.02);
  EXPECT_TRUE(a.continuous_limit);
  EXPECT_EQ(back.values, fit.values);
  // The same bytes again: nothing is lost on the way.
  EXPECT_EQ(EncodeFit(status, back), bytes);
}

TEST(FitCodecTest, TruncatedOrPaddedBytesAreRefused) {
  const std::string bytes = EncodeFit(Status::Ok(), SomeFit());
  Status status;
  EffectFit back;
  for (size_t cut :
       {size_t{0}, size_t{3}, bytes.size() / 2, bytes.size() - 1}) {
    EXPECT_FALSE(DecodeFit(bytes.substr(0, cut), &status, &back)) << cut;
  }
  EXPECT_FALSE(DecodeFit(bytes + "x", &status, &back));
  std::vector<Vec6<double>> residuals(3, Vec6<double>::Constant(-2.5));
  const std::string r = EncodeResiduals(Status::Ok(), residuals);
  std::vector<Vec6<double>> back_residuals;
  ASSERT_TRUE(DecodeResiduals(r, &status, &back_residuals));
  EXPECT_EQ(back_residuals, residuals);
  EXPECT_FALSE(
      DecodeResiduals(r.substr(0, r.size() - 8), &status, &back_residuals));
}

}  // namespace
}  // namespace kcrig
