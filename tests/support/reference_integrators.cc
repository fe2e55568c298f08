#include "tests/support/reference_integrators.h"

#include <cvode/cvode.h>
#include <nvector/nvector_serial.h>
#include <sunlinsol/sunlinsol_dense.h>
#include <sunmatrix/sunmatrix_dense.h>

#include <string>

#include "Eigen/LU"

namespace kcrig {
namespace {

struct OdeData {
  const SuspensionModel<double>* model;
  const LoadFunction* load;
};

// x = (y, z): dy/dt = V(y) z, dz/dt = M^-1 Q(t, y, z).
int Rhs(sunrealtype t, N_Vector x, N_Vector xdot, void* user_data) {
  const auto* data = static_cast<const OdeData*>(user_data);
  const Eigen::Map<const Eigen::Matrix<double, 12, 1>> state(
      N_VGetArrayPointer(x));
  Eigen::Map<Eigen::Matrix<double, 12, 1>> rate(N_VGetArrayPointer(xdot));
  const Vec6<double> y = state.head<6>();
  const Vec6<double> z = state.tail<6>();
  GeneralizedForce<double> g;
  data->model->Evaluate((*data->load)(t), y, z, false, &g);
  rate.head<6>() = data->model->KinematicMatrix(y) * z;
  // M is diagonal (principal axes), so M^-1 Q is a division.
  rate.tail<6>() =
      data->model->mass_matrix().diagonal().cwiseInverse().cwiseProduct(g.q);
  return 0;
}

}  // namespace

Status IntegrateWithCvode(const SuspensionModel<double>& model,
                          const LoadFunction& load,
                          const ModelState<double>& initial,
                          const std::vector<double>& times,
                          const CvodeOptions& options, CvodeResult* result) {
  SUNContext context;
  if (SUNContext_Create(nullptr, &context) != 0) {
    return Status::Error("CVODE: SUNContext_Create failed");
  }
  N_Vector x = N_VNew_Serial(12, context);
  N_Vector atol = N_VNew_Serial(12, context);
  Eigen::Map<Eigen::Matrix<double, 12, 1>> xs(N_VGetArrayPointer(x));
  xs << initial.y, initial.z;
  Eigen::Map<Eigen::Matrix<double, 12, 1>> as(N_VGetArrayPointer(atol));
  as.head<6>().setConstant(options.absolute_tolerance_position);
  as.tail<6>().setConstant(options.absolute_tolerance_velocity);

  OdeData data{&model, &load};
  void* cvode = CVodeCreate(CV_BDF, context);
  SUNMatrix matrix = SUNDenseMatrix(12, 12, context);
  SUNLinearSolver solver = SUNLinSol_Dense(x, matrix, context);
  Status status = Status::Ok();
  if (CVodeInit(cvode, Rhs, 0.0, x) != CV_SUCCESS ||
      CVodeSVtolerances(cvode, options.relative_tolerance, atol) !=
          CV_SUCCESS ||
      CVodeSetUserData(cvode, &data) != CV_SUCCESS ||
      CVodeSetLinearSolver(cvode, solver, matrix) != CV_SUCCESS ||
      CVodeSetMaxNumSteps(cvode, 10000000) != CV_SUCCESS) {
    status = Status::Error("CVODE: set-up failed");
  }
  result->y.clear();
  for (double t_out : times) {
    if (!status.ok()) break;
    sunrealtype t_reached = 0;
    const int flag = CVode(cvode, t_out, x, &t_reached, CV_NORMAL);
    if (flag < 0) {
      status = Status::Error("CVODE failed at t = " + std::to_string(t_out) +
                             " (flag " + std::to_string(flag) + ")");
      break;
    }
    result->y.push_back(xs.head<6>());
  }
  CVodeGetNumRhsEvals(cvode, &result->rhs_evaluations);
  CVodeGetNumSteps(cvode, &result->steps);
  CVodeFree(&cvode);
  SUNLinSolFree(solver);
  SUNMatDestroy(matrix);
  N_VDestroy(atol);
  N_VDestroy(x);
  SUNContext_Free(&context);
  return status;
}

void ExplicitEulerStep(const SuspensionModel<double>& model,
                       const RigLoad<double>& load, double h,
                       ModelState<double>* state) {
  GeneralizedForce<double> g;
  model.Evaluate(load, state->y, state->z, false, &g);
  const Vec6<double> y_rate = model.KinematicMatrix(state->y) * state->z;
  state->z +=
      h * model.mass_matrix().diagonal().cwiseInverse().cwiseProduct(g.q);
  state->y += h * y_rate;
}

}  // namespace kcrig
