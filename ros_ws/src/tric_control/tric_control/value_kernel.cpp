// TRIC's objective at one configuration, compiled: the features y = phi(q) over all ordered
// landmark pairs and their Jacobian (tric_learning.features), the value f and its gradient
// (tric_learning.value_function), g = (df/dy)(dphi/dq), and the domain rows
// (tric_control.motion_rate.ValueObjective). The same arithmetic as those Python modules, which
// stay the reference (tests compare the two); here in one call instead of about sixty numpy calls.
// Units: m, rad.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>
#include <vector>

namespace py = pybind11;

namespace {

using Array = py::array_t<double, py::array::c_style | py::array::forcecast>;
using Indices = py::array_t<long, py::array::c_style | py::array::forcecast>;

std::vector<double> doubles(const Array &a) { return {a.data(), a.data() + a.size()}; }
std::vector<long> longs(const Indices &a) { return {a.data(), a.data() + a.size()}; }

class ValueKernel {
 public:
  // count: landmarks L; first, second (P,): the pairs; signs (P, E): +1 where data.J's column e
  // moves the pair's second landmark only, -1 its first only, else 0; q_column (E,): the q entry
  // each column drives; kept, low, span, factor (s,): the kept features and their scaling; w1 (K,
  // s), w2 (K,), w3 (s,), b1 (K,): the value function; moving (m,): the kept features (indices
  // into u) a step can change; domain_rows, domain_margin: how many domain rows and how far u may leave [0,
  // 1]; rho, delta: TRIC's step weight and asked fall of f per tick.
  ValueKernel(long count, const Indices &first, const Indices &second, const Array &signs,
              const Indices &q_column, long n, const Indices &kept, const Array &low,
              const Array &span, const Array &factor, const Array &w1, const Array &w2,
              const Array &w3, const Array &b1, const Indices &moving, long domain_rows,
              double domain_margin, double rho, double delta)
      : count_(count), first_(longs(first)), second_(longs(second)), signs_(doubles(signs)),
        q_column_(longs(q_column)), n_(n), kept_(longs(kept)), low_(doubles(low)),
        span_(doubles(span)), factor_(doubles(factor)), w1_(doubles(w1)), w2_(doubles(w2)),
        w3_(doubles(w3)), b1_(doubles(b1)), moving_(longs(moving)), domain_rows_(domain_rows),
        domain_margin_(domain_margin), rho_(rho), delta_(delta) {
    pairs_ = static_cast<long>(first_.size());
    columns_ = static_cast<long>(q_column_.size());
    kept_count_ = static_cast<long>(kept_.size());
    hidden_ = static_cast<long>(w2_.size());
    if (static_cast<long>(second_.size()) != pairs_ ||
        static_cast<long>(signs_.size()) != pairs_ * columns_)
      throw std::invalid_argument("value kernel: pairs and signs disagree in size");
    if (static_cast<long>(low_.size()) != kept_count_ ||
        static_cast<long>(span_.size()) != kept_count_ ||
        static_cast<long>(factor_.size()) != kept_count_ ||
        static_cast<long>(w3_.size()) != kept_count_ ||
        static_cast<long>(b1_.size()) != hidden_ ||
        static_cast<long>(w1_.size()) != hidden_ * kept_count_)
      throw std::invalid_argument("value kernel: the value function's arrays disagree in size");
    for (long p = 0; p < pairs_; ++p)
      if (first_[p] < 0 || first_[p] >= count_ || second_[p] < 0 || second_[p] >= count_)
        throw std::invalid_argument("value kernel: a pair refers to no landmark");
    for (long c : q_column_)
      if (c < 0 || c >= n_) throw std::invalid_argument("value kernel: a column drives no q entry");
    for (long k : kept_)
      if (k < 0 || k >= 4 * pairs_) throw std::invalid_argument("value kernel: a kept feature is out of range");
    for (long k : moving_)
      if (k < 0 || k >= kept_count_) throw std::invalid_argument("value kernel: a moving feature is out of range");
  }

  // placements (L, 4, 4): the landmarks' homogeneous world poses; jacobian (6, E): data.J after
  // pin.computeJointJacobians (world frame, linear rows first). Returns (value, u (s,), df/du (s,),
  // g (n,), hessian (n, n) = 2 rho g g^T, linear (n,) = 2 rho delta g, |g|, domain rows (k, n),
  // domain margins (k,), and the domain rows' features as indices into u (k,)).
  py::tuple evaluate(const Array &placements, const py::array_t<double> &jacobian) const {
    if (placements.ndim() != 3 || placements.shape(0) != count_ || placements.shape(1) != 4 ||
        placements.shape(2) != 4)
      throw std::invalid_argument("value kernel: placements must be (L, 4, 4)");
    if (jacobian.ndim() != 2 || jacobian.shape(0) != 6 || jacobian.shape(1) != columns_)
      throw std::invalid_argument("value kernel: the joint Jacobian must be (6, E)");
    const double *pose = placements.data();
    auto J = jacobian.unchecked<2>();
    const long L = count_, E = columns_, n = n_;
    // positions x (L, 3) and rotations R (L, 3, 3)
    std::vector<double> x(3 * L), R(9 * L);
    for (long k = 0; k < L; ++k)
      for (int a = 0; a < 3; ++a) {
        x[3 * k + a] = pose[16 * k + 4 * a + 3];
        for (int b = 0; b < 3; ++b) R[9 * k + 3 * a + b] = pose[16 * k + 4 * a + b];
      }
    // the velocity of each landmark as if fixed to the body column e moves: V (L, E, 3)
    std::vector<double> V(3 * L * E);
    for (long k = 0; k < L; ++k) {
      const double *p = &x[3 * k];
      for (long e = 0; e < E; ++e) {
        double *v = &V[3 * (k * E + e)];
        const double wx = J(3, e), wy = J(4, e), wz = J(5, e);
        v[0] = J(0, e) + (wy * p[2] - wz * p[1]);
        v[1] = J(1, e) + (wz * p[0] - wx * p[2]);
        v[2] = J(2, e) + (wx * p[1] - wy * p[0]);
      }
    }
    const long d = 4 * pairs_;
    std::vector<double> y(d), jac(d * n, 0.0);
    for (long p = 0; p < pairs_; ++p) {
      const long i = first_[p], j = second_[p];
      const double *Ri = &R[9 * i];
      double o[3];
      for (int a = 0; a < 3; ++a) o[a] = x[3 * j + a] - x[3 * i + a];
      for (int a = 0; a < 3; ++a)
        y[4 * p + a] = Ri[a] * o[0] + Ri[3 + a] * o[1] + Ri[6 + a] * o[2];
      const double distance = std::sqrt(o[0] * o[0] + o[1] * o[1] + o[2] * o[2]);
      y[4 * p + 3] = distance;
      const double scale = 1.0 / std::max(distance, 1e-12);
      const double u0 = o[0] * scale, u1 = o[1] * scale, u2 = o[2] * scale;
      for (long e = 0; e < E; ++e) {
        const double s = signs_[p * E + e];
        if (s == 0.0) continue;
        const double *v = &V[3 * (j * E + e)];
        const long c = q_column_[e];
        for (int a = 0; a < 3; ++a)
          jac[(4 * p + a) * n + c] += s * (Ri[a] * v[0] + Ri[3 + a] * v[1] + Ri[6 + a] * v[2]);
        jac[(4 * p + 3) * n + c] += s * (u0 * v[0] + u1 * v[1] + u2 * v[2]);
      }
    }
    // the value function on the scaled kept features
    const long s_count = kept_count_;
    py::array_t<double> u_out(s_count), gradient_out(s_count);
    double *u = u_out.mutable_data(), *df_du = gradient_out.mutable_data();
    double value = 0.0;
    for (long k = 0; k < s_count; ++k) {
      u[k] = (y[kept_[k]] - low_[k]) / span_[k];
      value += u[k] * w3_[k];
      df_du[k] = w3_[k];
    }
    for (long h = 0; h < hidden_; ++h) {
      const double *row = &w1_[h * s_count];
      double a = b1_[h];
      for (long k = 0; k < s_count; ++k) a += row[k] * u[k];
      const double z = 0.5 * (1.0 + std::tanh(0.5 * a));
      value += z * w2_[h];
      const double slope = w2_[h] * z * (1.0 - z);
      for (long k = 0; k < s_count; ++k) df_du[k] += row[k] * slope;
    }
    // g = (df/dy)(dphi/dq)
    py::array_t<double> g_out(n);
    double *g = g_out.mutable_data();
    std::fill(g, g + n, 0.0);
    for (long k = 0; k < s_count; ++k) {
      const double weight = df_du[k] * factor_[k];
      const double *row = &jac[kept_[k] * n];
      for (long c = 0; c < n; ++c) g[c] += weight * row[c];
    }
    double norm2 = 0.0;
    for (long c = 0; c < n; ++c) norm2 += g[c] * g[c];
    const double two_rho = 2.0 * rho_;
    py::array_t<double> hessian_out({n, n}), linear_out(n);
    double *hessian = hessian_out.mutable_data(), *linear = linear_out.mutable_data();
    for (long r = 0; r < n; ++r) {
      linear[r] = two_rho * delta_ * g[r];
      for (long c = 0; c < n; ++c) hessian[r * n + c] = two_rho * (g[r] * g[c]);
    }
    // the domain rows: the moving features nearest a bound of [-margin, 1 + margin], nearest first
    const long m = static_cast<long>(moving_.size());
    std::vector<double> margins(m), to_low(m), to_high(m);
    for (long k = 0; k < m; ++k) {
      const double scaled = u[moving_[k]];
      to_low[k] = scaled + domain_margin_;
      to_high[k] = (1.0 + domain_margin_) - scaled;
      margins[k] = std::min(to_low[k], to_high[k]);
    }
    std::vector<long> order(m);
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(),
                     [&](long a, long b) { return margins[a] < margins[b]; });
    const long rows = std::min(domain_rows_, m);
    py::array_t<double> rows_out({rows, n}), margins_out(rows);
    py::array_t<long> features_out(rows);
    double *domain = rows_out.mutable_data(), *domain_margins = margins_out.mutable_data();
    long *domain_features = features_out.mutable_data();
    for (long r = 0; r < rows; ++r) {
      const long k = order[r], feature = moving_[k];
      const double sign = to_low[k] <= to_high[k] ? 1.0 : -1.0;
      const double scale = factor_[feature] * sign;
      const double *row = &jac[kept_[feature] * n];
      for (long c = 0; c < n; ++c) domain[r * n + c] = row[c] * scale;
      domain_margins[r] = margins[k];
      domain_features[r] = feature;
    }
    return py::make_tuple(value, u_out, gradient_out, g_out, hessian_out, linear_out,
                          std::sqrt(norm2), rows_out, margins_out, features_out);
  }

 private:
  long count_;
  std::vector<long> first_, second_;
  std::vector<double> signs_;
  std::vector<long> q_column_;
  long n_;
  std::vector<long> kept_;
  std::vector<double> low_, span_, factor_, w1_, w2_, w3_, b1_;
  std::vector<long> moving_;
  long domain_rows_;
  double domain_margin_, rho_, delta_;
  long pairs_ = 0, columns_ = 0, kept_count_ = 0, hidden_ = 0;
};

}  // namespace

PYBIND11_MODULE(_value_kernel, module) {
  module.doc() = "TRIC's objective (features, Jacobian, value gradient, domain rows), compiled";
  py::class_<ValueKernel>(module, "ValueKernel")
      .def(py::init<long, const Indices &, const Indices &, const Array &, const Indices &, long,
                    const Indices &, const Array &, const Array &, const Array &, const Array &,
                    const Array &, const Array &, const Array &, const Indices &, long, double,
                    double, double>())
      .def("evaluate", &ValueKernel::evaluate);
}
