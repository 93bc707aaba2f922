// Pinocchio's C++ library (from the pip `pin` wheel, which ships headers and
// libpinocchio_default.so) on the Puma 560 of model/puma560.toml, timed per call without any
// Python overhead. Build and run with bench/pinocchio_puma560.sh.
#include <chrono>
#include <cstdio>
#include <pinocchio/multibody.hpp>
#include <pinocchio/algorithm/aba.hpp>
#include <pinocchio/algorithm/crba.hpp>
#include <pinocchio/algorithm/rnea.hpp>

using namespace pinocchio;

int main() {
  const double d[6] = {0, 0, 0.15005, 0.4318, 0, 0};
  const double a[6] = {0, 0.4318, 0.0203, 0, 0, 0};
  const double al[6] = {M_PI / 2, 0, -M_PI / 2, M_PI / 2, -M_PI / 2, 0};
  const double m[6] = {0, 17.4, 4.8, 0.82, 0.34, 0.09};
  const double c[6][3] = {{0, 0, 0}, {-0.3638, 0.006, 0.2275}, {-0.0203, -0.0141, 0.070},
                          {0, 0.019, 0}, {0, 0, 0}, {0, 0, 0.032}};
  const double I[6][3] = {{0, 0.35, 0}, {0.13, 0.524, 0.539}, {0.066, 0.086, 0.0125},
                          {1.8e-3, 1.3e-3, 1.8e-3}, {0.3e-3, 0.4e-3, 0.3e-3},
                          {0.15e-3, 0.15e-3, 0.04e-3}};
  Model model;
  JointIndex parent = 0;
  SE3 placement = SE3::Identity();
  for (int i = 0; i < 6; ++i) {
    JointIndex j = model.addJoint(parent, JointModelRZ(), placement, "j" + std::to_string(i));
    SE3 t(Eigen::AngleAxisd(al[i], Eigen::Vector3d::UnitX()).toRotationMatrix(),
          Eigen::Vector3d(a[i], 0, d[i]));
    Inertia in(m[i], Eigen::Vector3d(c[i][0], c[i][1], c[i][2]),
               Eigen::Vector3d(I[i][0], I[i][1], I[i][2]).asDiagonal().toDenseMatrix());
    model.appendBodyToJoint(j, t.act(in), SE3::Identity());
    parent = j;
    placement = t;
  }
  model.gravity.linear(Eigen::Vector3d(0, 0, -9.81));
  Data data(model);
  Eigen::VectorXd q(6), v(6), acc(6);
  q << 0.1, -0.4, 0.7, 0.3, -0.2, 0.5;
  v << 0.5, -1.0, 0.8, 1.2, -0.7, 0.9;
  acc << 0.3, 0.2, -0.4, 1.0, 0.5, -0.6;
  Eigen::VectorXd tau = rnea(model, data, q, v, acc);
  Eigen::VectorXd g0 = computeGeneralizedGravity(model, data, Eigen::VectorXd::Zero(6));
  std::printf("g(0) = [%.4f %.4f %.4f %.4f %.4f %.4f]\n", g0[0], g0[1], g0[2], g0[3], g0[4], g0[5]);
  Model model0 = model;
  model0.gravity.setZero();
  Data data0(model0);
  auto time = [](const char *name, auto f) {
    const int n = 200000;
    double best = 1e30;
    for (int r = 0; r < 7; ++r) {
      auto t0 = std::chrono::steady_clock::now();
      for (int i = 0; i < n; ++i) f();
      double ns = std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - t0).count() / n;
      if (ns < best) best = ns;
    }
    std::printf("  %-34s %8.1f ns\n", name, best);
  };
  std::printf("pinocchio C++ (pip pin %s), best of 7 x 200000 calls\n", PINOCCHIO_VERSION);
  time("crba (M)", [&] { crba(model, data, q); });
  time("nonLinearEffects, g = 0 (C qd)", [&] { nonLinearEffects(model0, data0, q, v); });
  time("computeGeneralizedGravity (g)", [&] { computeGeneralizedGravity(model, data, q); });
  time("rnea (tau)", [&] { rnea(model, data, q, v, acc); });
  time("aba (qdd)", [&] { aba(model, data, q, v, tau); });
  return 0;
}
