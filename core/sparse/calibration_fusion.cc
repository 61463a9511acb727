#include "core/sparse/calibration_fusion.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "core/sparse/calibration_uncertainty.h"
#include "core/sparse/fixed_text.h"
#include "core/sparse/sparse_reconstruction.h"

namespace dfsm {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr int64_t kInt64Min = std::numeric_limits<int64_t>::min();
constexpr int64_t kInt64Max = std::numeric_limits<int64_t>::max();
constexpr const char* kOutcomeNames[] = {"fused", "started", "outlier", "restarted-after-change",
                                         "refused"};

// log Gamma(k/2 + 1) by the recurrence from Gamma(1) or Gamma(1/2): exact for
// the half-integers a chi-square needs, and free of lgamma's global sign.
double LogGammaOfHalfPlusOne(int k) {
  double log_gamma = k % 2 == 0 ? 0.0 : 0.5 * std::log(std::acos(-1.0));
  for (double a = k % 2 == 0 ? 1.0 : 0.5; a <= 0.5 * k; a += 1.0) log_gamma += std::log(a);
  return log_gamma;
}

Eigen::Vector3d Theta(const CameraModel& camera) { return {camera.f, camera.k1, camera.k2}; }

// Positive definite whatever the units: a positive diagonal and a regular
// correlation matrix. The raw eigenvalues mix px^2 with squares of
// dimensionless coefficients, orders of magnitude apart, so a threshold on
// them would judge the units rather than the matrix.
bool PositiveDefinite(const Eigen::Matrix3d& m) {
  if (!m.allFinite() || !(m.diagonal().minCoeff() > 0.0)) return false;
  const Eigen::Vector3d scale = m.diagonal().cwiseSqrt().cwiseInverse();
  const Eigen::Matrix3d correlation = scale.asDiagonal() * m * scale.asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(correlation, Eigen::EigenvaluesOnly);
  return solver.info() == Eigen::Success && solver.eigenvalues().minCoeff() > 1e-10;
}

// Exactly symmetric, so that sums of inverses stay symmetric too.
Eigen::Matrix3d Inverse(const Eigen::Matrix3d& spd) {
  const Eigen::Matrix3d inverse = spd.llt().solve(Eigen::Matrix3d::Identity());
  return 0.5 * (inverse + inverse.transpose());
}

double Chi2(const Eigen::Vector3d& d, const Eigen::Matrix3d& covariance) {
  return d.dot(covariance.llt().solve(d));
}

// Why `sample` cannot be fused at all (empty if it can); `*covariance` gets
// its covariance made exactly symmetric.
std::string Unusable(const CalibrationSample& sample, Eigen::Matrix3d* covariance) {
  const CameraModel& c = sample.camera;
  if (c.width <= 0 || c.height <= 0) return "the image size is not positive";
  if (!(std::isfinite(c.f) && c.f > 0.0 && std::isfinite(c.k1) && std::isfinite(c.k2) &&
        std::isfinite(c.cx) && std::isfinite(c.cy)))
    return "f, k1, k2 or the principal point is not finite (or f <= 0)";
  const Eigen::Matrix3d& C = sample.covariance;
  if (!C.allFinite()) return "the covariance is not finite";
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < a; ++b)
      if (std::abs(C(a, b) - C(b, a)) > 1e-6 * std::sqrt(std::abs(C(a, a) * C(b, b))))
        return "the covariance is not symmetric";
  *covariance = 0.5 * (C + C.transpose());
  if (!PositiveDefinite(*covariance))
    return "the covariance is not positive definite (an intrinsic held fixed, or f and the "
           "distortion indistinguishable)";
  return "";
}

std::string Geometry(const CameraModel& c) {
  return std::to_string(c.width) + "x" + std::to_string(c.height) + " with principal point (" +
         FixedText(c.cx, 3) + ", " + FixedText(c.cy, 3) + ")";
}

}  // namespace

double ChiSquareCdf(double x, int degrees_of_freedom) {
  if (degrees_of_freedom < 1 || degrees_of_freedom > 1000)
    throw std::invalid_argument("chi-square: degrees of freedom must be in 1..1000");
  if (std::isnan(x)) return kNaN;
  if (x <= 0.0) return 0.0;
  const double a = 0.5 * degrees_of_freedom, z = 0.5 * x;
  // The upper tail beyond here is below 1e-300: 1 to double precision, and
  // the series would need more terms than it is worth.
  if (z > a + 40.0 * std::sqrt(a) + 750.0) return 1.0;
  // P(a, z) = z^a e^-z / Gamma(a + 1) * sum_n z^n / ((a + 1) ... (a + n)):
  // positive terms, so no cancellation; rescaled so that large z cannot overflow.
  double term = 1.0, sum = 1.0, log_scale = 0.0;
  for (int n = 1; n < 100000 && term > 1e-17 * sum; ++n) {
    term *= z / (a + n);
    sum += term;
    if (sum > 1e200) {
      sum *= 1e-200;
      term *= 1e-200;
      log_scale += 200.0 * std::log(10.0);
    }
  }
  const double log_p =
      a * std::log(z) - z - LogGammaOfHalfPlusOne(degrees_of_freedom) + std::log(sum) + log_scale;
  return std::min(1.0, std::exp(log_p));
}

double ChiSquareQuantile(double probability, int degrees_of_freedom) {
  if (!(probability > 0.0 && probability < 1.0))
    throw std::invalid_argument("chi-square quantile: probability must be in (0, 1)");
  double lo = 0.0, hi = 1.0;
  while (ChiSquareCdf(hi, degrees_of_freedom) < probability) {
    lo = hi;
    hi *= 2.0;
  }
  for (int i = 0; i < 200 && hi - lo > 1e-13 * hi; ++i) {
    const double mid = 0.5 * (lo + hi);
    (ChiSquareCdf(mid, degrees_of_freedom) < probability ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

void CalibrationFusionOptions::Check() const {
  const auto require = [](bool ok, const char* what) {
    if (!ok) throw std::invalid_argument(std::string("calibration fusion options: ") + what);
  };
  require(consistency_probability > 0.0 && consistency_probability < 1.0,
          "consistency_probability must be in (0, 1)");
  require(min_bursts_for_reliable >= 1, "min_bursts_for_reliable must be at least 1");
  require(max_reliable_sigma_f_percent > 0.0 && std::isfinite(max_reliable_sigma_f_percent),
          "max_reliable_sigma_f_percent must be positive and finite");
  require(max_reliable_distortion_sigma_px > 0.0 && std::isfinite(max_reliable_distortion_sigma_px),
          "max_reliable_distortion_sigma_px must be positive and finite");
  require(history_limit >= 0, "history_limit must not be negative");
  require(principal_point_tolerance_px >= 0.0 && std::isfinite(principal_point_tolerance_px),
          "principal_point_tolerance_px must be non-negative and finite");
}

const char* FusionOutcomeName(FusionOutcome outcome) {
  return kOutcomeNames[static_cast<int>(outcome)];
}

std::optional<FusionOutcome> FusionOutcomeFromName(const std::string& name) {
  for (int i = 0; i < 5; ++i)
    if (name == kOutcomeNames[i]) return static_cast<FusionOutcome>(i);
  return std::nullopt;
}

CalibrationFusion::CalibrationFusion(CalibrationFusionOptions options) : options_(options) {
  options_.Check();
  gate_ = ChiSquareQuantile(options_.consistency_probability, 3);
}

FusionOutcome CalibrationFusion::Add(const CalibrationSample& sample, std::string* reason) {
  Eigen::Matrix3d C;
  std::string why = Unusable(sample, &C);
  const CameraModel& c = sample.camera;
  if (why.empty() && !empty() &&
      (c.width != geometry_.width || c.height != geometry_.height ||
       !(std::abs(c.cx - geometry_.cx) <= options_.principal_point_tolerance_px) ||
       !(std::abs(c.cy - geometry_.cy) <= options_.principal_point_tolerance_px)))
    why = "image " + Geometry(c) + " is not the fusion's " + Geometry(geometry_) +
          ": f, k1, k2 of another geometry need a fusion of their own";
  FusionOutcome outcome = FusionOutcome::kRefused;
  double chi2 = kNaN;
  const Eigen::Vector3d theta = Theta(c);
  if (!why.empty()) {
    ++counts_.refused;
  } else if (empty()) {
    geometry_ = c;
    Accumulate(theta, Inverse(C));
    outcome = FusionOutcome::kStarted;
    ++counts_.started;
  } else {
    // The fused estimate does not contain this burst, so the difference's
    // covariance is the sum of both.
    chi2 = Chi2(theta - Mean(), C + covariance());
    const std::string test = "chi2 " + FixedText(chi2) + (chi2 <= gate_ ? " <= " : " > ") +
                             FixedText(gate_) + " against the fusion of " +
                             std::to_string(bursts_) + (bursts_ == 1 ? " burst" : " bursts");
    // Likewise against the pending outlier, itself never fused.
    const double chi2_pending =
        pending_ ? Chi2(theta - Theta(pending_->camera), C + pending_->covariance) : kNaN;
    if (chi2 <= gate_) {
      Accumulate(theta, Inverse(C));
      pending_.reset();
      outcome = FusionOutcome::kFused;
      ++counts_.fused;
      why = test;
    } else if (chi2_pending <= gate_) {
      why = test + ", but chi2 " + FixedText(chi2_pending) + " against the previous outlier (" +
            pending_->job + "): the camera changed, the fusion restarts from both";
      information_.setZero();
      information_vector_.setZero();
      bursts_ = 0;
      Accumulate(Theta(pending_->camera), Inverse(pending_->covariance));
      Accumulate(theta, Inverse(C));
      pending_.reset();
      outcome = FusionOutcome::kRestartedAfterChange;
      ++counts_.restarts;
    } else {
      why = test + ": left out" +
            (pending_ ? " (and chi2 " + FixedText(chi2_pending) + " against the previous outlier)"
                      : std::string());
      pending_ = sample;
      pending_->covariance = C;
      outcome = FusionOutcome::kOutlier;
      ++counts_.outliers;
    }
  }
  Record(sample, outcome, why, chi2);
  if (reason) *reason = why;
  return outcome;
}

void CalibrationFusion::Accumulate(const Eigen::Vector3d& theta,
                                   const Eigen::Matrix3d& information) {
  information_ += information;
  information_vector_ += information * theta;
  ++bursts_;
}

void CalibrationFusion::Record(const CalibrationSample& sample, FusionOutcome outcome,
                               const std::string& reason, double chi2) {
  if (options_.history_limit == 0) return;
  HistoryEntry entry;
  entry.job = sample.job;
  entry.time_ms = sample.time_ms;
  entry.f = sample.camera.f;
  entry.k1 = sample.camera.k1;
  entry.k2 = sample.camera.k2;
  const double variance_f = sample.covariance(0, 0);
  entry.sigma_f_percent =
      variance_f >= 0.0 && entry.f > 0.0 ? 100.0 * std::sqrt(variance_f) / entry.f : kNaN;
  entry.outcome = outcome;
  entry.reason = reason;
  entry.chi2 = chi2;
  entry.fused_bursts_after = bursts_;
  entry.fused_f_after = empty() ? kNaN : Mean()(0);
  const size_t limit = static_cast<size_t>(options_.history_limit);
  if (history_.size() >= limit) history_.erase(history_.begin(), history_.end() - (limit - 1));
  history_.push_back(entry);
}

void CalibrationFusion::Reset() {
  bursts_ = 0;
  information_.setZero();
  information_vector_.setZero();
  geometry_ = CameraModel();
  pending_.reset();
}

Eigen::Vector3d CalibrationFusion::Mean() const {
  return information_.llt().solve(information_vector_);
}

CameraModel CalibrationFusion::camera() const {
  if (empty()) throw std::logic_error("calibration fusion: no burst fused yet");
  CameraModel fused = geometry_;
  const Eigen::Vector3d mean = Mean();
  fused.f = mean(0);
  fused.k1 = mean(1);
  fused.k2 = mean(2);
  return fused;
}

Eigen::Matrix3d CalibrationFusion::covariance() const {
  if (empty()) throw std::logic_error("calibration fusion: no burst fused yet");
  return Inverse(information_);
}

double CalibrationFusion::sigma_f_percent() const {
  return 100.0 * std::sqrt(covariance()(0, 0)) / Mean()(0);
}

double CalibrationFusion::distortion_sigma_px() const {
  CalibrationUncertainty uncertainty;
  uncertainty.available = true;
  uncertainty.covariance = covariance();
  PropagateToDistortion(camera(), &uncertainty);
  return uncertainty.distortion_sigma_px;
}

bool CalibrationFusion::reliable() const {
  return !empty() && bursts_ >= options_.min_bursts_for_reliable &&
         sigma_f_percent() < options_.max_reliable_sigma_f_percent &&
         distortion_sigma_px() < options_.max_reliable_distortion_sigma_px;
}

std::vector<std::string> CalibrationFusion::UnreliableReasons() const {
  if (empty()) return {"no burst fused yet"};
  std::vector<std::string> reasons;
  if (bursts_ < options_.min_bursts_for_reliable)
    reasons.push_back(std::to_string(bursts_) + " of " +
                      std::to_string(options_.min_bursts_for_reliable) + " bursts fused");
  if (!(sigma_f_percent() < options_.max_reliable_sigma_f_percent))
    reasons.push_back("focal length sigma " + FixedText(sigma_f_percent()) + " %, needs < " +
                      FixedText(options_.max_reliable_sigma_f_percent) + " %");
  if (!(distortion_sigma_px() < options_.max_reliable_distortion_sigma_px))
    reasons.push_back("distortion sigma " + FixedText(distortion_sigma_px()) + " px, needs < " +
                      FixedText(options_.max_reliable_distortion_sigma_px) + " px");
  return reasons;
}

namespace {

using nlohmann::json;

json Number(double value) { return std::isfinite(value) ? json(value) : json(nullptr); }

json MatrixJson(const Eigen::Matrix3d& m) {
  json rows = json::array();
  for (int r = 0; r < 3; ++r) rows.push_back({m(r, 0), m(r, 1), m(r, 2)});
  return rows;
}

[[noreturn]] void Damaged(const std::string& field, const std::string& what) {
  throw std::runtime_error("calibration fusion: field '" + field + "' " + what);
}

// A value of the stored state with its path ("history[3].chi2") for the
// message when it is not what ToJson writes.
struct Field {
  const json& value;
  std::string name;

  Field operator[](const char* key) const {
    const std::string child = name.empty() ? key : name + "." + key;
    if (!value.is_object()) Damaged(name, "is not an object");
    if (!value.contains(key)) Damaged(child, "is missing");
    return {value[key], child};
  }
  Field operator[](size_t i) const { return {value[i], name + "[" + std::to_string(i) + "]"}; }
  // null stands for a number that was not finite (ToJson writes NaN so).
  double NumberOrNull() const {
    if (value.is_null()) return kNaN;
    if (!value.is_number()) Damaged(name, "is not a number");
    return value.get<double>();
  }
  double Finite() const {
    if (!value.is_number() || !std::isfinite(value.get<double>()))
      Damaged(name, "is not a finite number");
    return value.get<double>();
  }
  int64_t Integer(int64_t min, int64_t max = std::numeric_limits<int>::max()) const {
    if (!value.is_number_integer() || value.get<int64_t>() < min || value.get<int64_t>() > max)
      Damaged(name, "is not an integer in " + std::to_string(min) + ".." + std::to_string(max));
    return value.get<int64_t>();
  }
  std::string String() const {
    if (!value.is_string()) Damaged(name, "is not a string");
    return value.get<std::string>();
  }
  Eigen::Vector3d Vector() const {
    if (!value.is_array() || value.size() != 3) Damaged(name, "is not an array of 3 numbers");
    Eigen::Vector3d v;
    for (size_t i = 0; i < 3; ++i) v(i) = (*this)[i].Finite();
    return v;
  }
  Eigen::Matrix3d Matrix() const {
    if (!value.is_array() || value.size() != 3) Damaged(name, "is not a 3x3 array");
    Eigen::Matrix3d m;
    for (size_t r = 0; r < 3; ++r) m.row(r) = (*this)[r].Vector().transpose();
    return m;
  }
  Eigen::Matrix3d SymmetricPositiveDefinite() const {
    const Eigen::Matrix3d m = Matrix();
    if (m != m.transpose() || !PositiveDefinite(m))
      Damaged(name, "is not symmetric positive definite");
    return m;
  }
};

}  // namespace

nlohmann::json CalibrationFusion::ToJson() const {
  json j = {{"format", "dfsm-calibration-fusion"},
            {"version", 1},
            {"empty", empty()},
            {"bursts", bursts_},
            {"reliable", reliable()},
            {"unreliable_reasons", UnreliableReasons()},
            {"consistency_gate_chi2", gate_},
            {"information_matrix", MatrixJson(information_)},
            {"information_vector",
             {information_vector_(0), information_vector_(1), information_vector_(2)}},
            {"counts",
             {{"started", counts_.started},
              {"fused", counts_.fused},
              {"outliers", counts_.outliers},
              {"restarts", counts_.restarts},
              {"refused", counts_.refused}}}};
  for (const char* key : {"geometry", "camera", "sigma_f_percent", "sigma_k1", "sigma_k2",
                          "distortion_sigma_px", "covariance", "pending_outlier"})
    j[key] = nullptr;
  if (!empty()) {
    const Eigen::Matrix3d fused_covariance = covariance();
    j["geometry"] = {{"width", geometry_.width},
                     {"height", geometry_.height},
                     {"cx", geometry_.cx},
                     {"cy", geometry_.cy}};
    j["camera"] = dfsm::ToJson(camera());
    j["sigma_f_percent"] = sigma_f_percent();
    j["sigma_k1"] = std::sqrt(fused_covariance(1, 1));
    j["sigma_k2"] = std::sqrt(fused_covariance(2, 2));
    j["distortion_sigma_px"] = distortion_sigma_px();
    j["covariance"] = MatrixJson(fused_covariance);
  }
  if (pending_)
    j["pending_outlier"] = {{"job", pending_->job},
                            {"time_ms", pending_->time_ms},
                            {"camera", dfsm::ToJson(pending_->camera)},
                            {"covariance", MatrixJson(pending_->covariance)}};
  json history = json::array();
  for (const HistoryEntry& e : history_)
    history.push_back({{"job", e.job},
                       {"time_ms", e.time_ms},
                       {"f", Number(e.f)},
                       {"k1", Number(e.k1)},
                       {"k2", Number(e.k2)},
                       {"sigma_f_percent", Number(e.sigma_f_percent)},
                       {"outcome", FusionOutcomeName(e.outcome)},
                       {"reason", e.reason},
                       {"chi2", Number(e.chi2)},
                       {"fused_bursts_after", e.fused_bursts_after},
                       {"fused_f_after", Number(e.fused_f_after)}});
  j["history"] = std::move(history);
  return j;
}

CalibrationFusion CalibrationFusion::FromJson(const nlohmann::json& j,
                                              CalibrationFusionOptions options) {
  if (!j.is_object()) throw std::runtime_error("calibration fusion: not a JSON object");
  const Field root{j, ""};
  if (root["version"].Integer(0) != 1) Damaged("version", "is not 1");
  CalibrationFusion fusion(options);
  fusion.bursts_ = static_cast<int>(root["bursts"].Integer(0));
  if (fusion.bursts_ > 0) {
    fusion.information_ = root["information_matrix"].SymmetricPositiveDefinite();
    fusion.information_vector_ = root["information_vector"].Vector();
    const Field geometry = root["geometry"];
    fusion.geometry_.width = static_cast<int>(geometry["width"].Integer(1));
    fusion.geometry_.height = static_cast<int>(geometry["height"].Integer(1));
    fusion.geometry_.cx = geometry["cx"].Finite();
    fusion.geometry_.cy = geometry["cy"].Finite();
  } else if (!root["information_matrix"].Matrix().isZero(0.0) ||
             !root["information_vector"].Vector().isZero(0.0)) {
    Damaged("information_matrix", "is not zero although bursts is 0");
  }
  const Field pending = root["pending_outlier"];
  if (!pending.value.is_null()) {
    if (fusion.empty()) Damaged(pending.name, "is set although bursts is 0");
    CalibrationSample sample;
    sample.job = pending["job"].String();
    sample.time_ms = pending["time_ms"].Integer(kInt64Min, kInt64Max);
    try {
      sample.camera = CameraModelFromJson(pending["camera"].value);
    } catch (const std::runtime_error& e) {
      Damaged("pending_outlier.camera", std::string("is not a camera: ") + e.what());
    }
    sample.covariance = pending["covariance"].SymmetricPositiveDefinite();
    fusion.pending_ = sample;
  }
  const Field counts = root["counts"];
  fusion.counts_.started = static_cast<int>(counts["started"].Integer(0));
  fusion.counts_.fused = static_cast<int>(counts["fused"].Integer(0));
  fusion.counts_.outliers = static_cast<int>(counts["outliers"].Integer(0));
  fusion.counts_.restarts = static_cast<int>(counts["restarts"].Integer(0));
  fusion.counts_.refused = static_cast<int>(counts["refused"].Integer(0));
  const Field history = root["history"];
  if (!history.value.is_array()) Damaged(history.name, "is not an array");
  const size_t size = history.value.size();
  for (size_t i = size - std::min(size, size_t(options.history_limit)); i < size; ++i) {
    const Field e = history[i];
    HistoryEntry entry;
    entry.job = e["job"].String();
    entry.time_ms = e["time_ms"].Integer(kInt64Min, kInt64Max);
    entry.f = e["f"].NumberOrNull();
    entry.k1 = e["k1"].NumberOrNull();
    entry.k2 = e["k2"].NumberOrNull();
    entry.sigma_f_percent = e["sigma_f_percent"].NumberOrNull();
    const std::optional<FusionOutcome> outcome = FusionOutcomeFromName(e["outcome"].String());
    if (!outcome) Damaged(e.name + ".outcome", "is not an outcome name");
    entry.outcome = *outcome;
    entry.reason = e["reason"].String();
    entry.chi2 = e["chi2"].NumberOrNull();
    entry.fused_bursts_after = static_cast<int>(e["fused_bursts_after"].Integer(0));
    entry.fused_f_after = e["fused_f_after"].NumberOrNull();
    fusion.history_.push_back(std::move(entry));
  }
  return fusion;
}

KnownCalibration FusedCalibrationPrior(const CameraModel& fused, double sigma_f_percent,
                                       double distortion_sigma_px, const std::string& source) {
  KnownCalibration known;
  known.camera = fused;
  known.mode = KnownCalibrationMode::kPrior;
  known.f_sigma_percent = std::max(sigma_f_percent, kMinFusedPriorSigmaFPercent);
  known.distortion_sigma_px = std::max(distortion_sigma_px, kMinFusedPriorDistortionPx);
  known.source = source;
  known.also_self_calibrate = true;
  known.check_fit = false;
  return known;
}

std::optional<CalibrationSample> FusionSampleOf(const SparseReconstruction& sparse,
                                                const std::string& job, std::string* why) {
  const std::optional<CameraModel> debiased = sparse.DebiasedCamera();
  if (!debiased) {
    *why = std::string("not estimated from the burst (") +
           CalibrationSourceName(sparse.calibration_used) + ")";
    return std::nullopt;
  }
  const CalibrationUncertainty& uncertainty =
      sparse.self_estimate ? sparse.self_estimate->uncertainty : sparse.uncertainty;
  if (!uncertainty.available) {
    *why = "no uncertainty: " + uncertainty.unavailable_reason;
    return std::nullopt;
  }
  const CalibrationVerdict& verdict =
      sparse.self_estimate ? sparse.self_estimate->verdict : sparse.verdict;
  if (verdict.quality == CalibrationQuality::kDegenerate) {
    *why = "degenerate (" + verdict.reasons.front() + ")";
    return std::nullopt;
  }
  CalibrationSample sample;
  sample.camera = *debiased;
  sample.covariance = uncertainty.covariance;
  sample.job = job;
  return sample;
}

}  // namespace dfsm
