// A hand-written ceres::CostFunction held to the autodiff of the residual it
// was derived from: what the cost functions' tests share.
#pragma once

#include <ceres/cost_function.h>
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

namespace dfsm {

// `analytic` and `autodiff` take the same parameter blocks and give, at
// `parameters`, the same residuals and every Jacobian block within 1e-9
// (relative beyond 1); `analytic` gives the same residuals without Jacobians
// as with them. `context` names the draw in a failure.
inline void ExpectSameResidualAndJacobians(const ceres::CostFunction& analytic,
                                           const ceres::CostFunction& autodiff,
                                           double const* const* parameters,
                                           const std::string& context) {
  ASSERT_EQ(analytic.parameter_block_sizes(), autodiff.parameter_block_sizes()) << context;
  const int residuals = analytic.num_residuals();
  ASSERT_EQ(residuals, autodiff.num_residuals()) << context;
  std::vector<std::vector<double>> j_analytic, j_autodiff;
  for (const int size : analytic.parameter_block_sizes()) {
    j_analytic.emplace_back(residuals * size, 0.0);
    j_autodiff.emplace_back(residuals * size, 0.0);
  }
  std::vector<double*> p_analytic, p_autodiff;
  for (size_t b = 0; b < j_analytic.size(); ++b) {
    p_analytic.push_back(j_analytic[b].data());
    p_autodiff.push_back(j_autodiff[b].data());
  }
  std::vector<double> r_analytic(residuals), r_autodiff(residuals), r_only(residuals);
  ASSERT_TRUE(analytic.Evaluate(parameters, r_analytic.data(), p_analytic.data())) << context;
  ASSERT_TRUE(autodiff.Evaluate(parameters, r_autodiff.data(), p_autodiff.data())) << context;
  ASSERT_TRUE(analytic.Evaluate(parameters, r_only.data(), nullptr)) << context;
  for (int k = 0; k < residuals; ++k) {
    EXPECT_NEAR(r_analytic[k], r_autodiff[k], 1e-9 * (1.0 + std::abs(r_autodiff[k]))) << context;
    EXPECT_EQ(r_only[k], r_analytic[k]) << context;
  }
  for (size_t b = 0; b < j_analytic.size(); ++b)
    for (size_t k = 0; k < j_analytic[b].size(); ++k)
      EXPECT_NEAR(j_analytic[b][k], j_autodiff[b][k], 1e-9 * (1.0 + std::abs(j_autodiff[b][k])))
          << "block " << b << " entry " << k << ", " << context;
}

}  // namespace dfsm
