#include "core/dense/plane_selection.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "core/dense/plane_sweep.h"

namespace dfsm {
namespace {

// RejectCostOutliers compares a pixel with the pixels of like texture: this
// many classes of equal size.
constexpr size_t kTextureClasses = 16;

// 1 - c_best / c_rival for the plane `best` of a cost curve, c_rival the
// lowest cost outside the valley that descends to `best` (walking out while
// the cost keeps rising), or its largest cost when there is no other valley.
// At most 1; at or below 0 where `best` is not a minimum of the curve.
float Distinctiveness(const float* curve, int n, int best) {
  const float c_best = curve[best];
  int left = best, right = best;
  while (left > 0 && curve[left - 1] >= curve[left] && curve[left - 1] < kNoCost) --left;
  while (right < n - 1 && curve[right + 1] >= curve[right] && curve[right + 1] < kNoCost) ++right;
  float rival = kNoCost, highest = c_best;
  for (int k = 0; k < n; ++k) {
    if (curve[k] >= kNoCost) continue;
    highest = std::max(highest, curve[k]);
    if (k < left || k > right) rival = std::min(rival, curve[k]);
  }
  if (rival >= kNoCost) rival = highest;
  return rival > 0.0f ? 1.0f - c_best / rival : 0.0f;
}

// The lowest slice of a cost curve (the first of equals).
int LowestSlice(const float* curve, int n) {
  int best = 0;
  for (int k = 1; k < n; ++k)
    if (curve[k] < curve[best]) best = k;
  return best;
}

// 255 where the curve's lowest slice `best` has a cost and is the first or
// the last: the minimum may lie beyond the curve.
uchar EdgeFlag(const float* curve, int n, int best) {
  return curve[best] < kNoCost && (best == 0 || best == n - 1) ? 255 : 0;
}

}  // namespace

void SelectCurve(const float* curve, int n, int first, int stride, float* plane, float* confidence,
                 uchar* at_edge) {
  const int best = LowestSlice(curve, n);
  const float c_best = curve[best];
  if (c_best >= kNoCost) {
    *plane = -1.0f;
    *confidence = 0.0f;
    *at_edge = 0;
    return;
  }
  *confidence = Distinctiveness(curve, n, best);
  float offset = 0.0f;
  if (best > 0 && best < n - 1 && curve[best - 1] < kNoCost && curve[best + 1] < kNoCost) {
    const float curvature = curve[best - 1] - 2.0f * c_best + curve[best + 1];
    if (curvature > 0.0f)
      offset = std::clamp(0.5f * (curve[best - 1] - curve[best + 1]) / curvature, -0.5f, 0.5f);
  }
  *plane = static_cast<float>(first + (best + offset) * stride);
  *at_edge = EdgeFlag(curve, n, best);
}

PlaneSelection SelectPlanes(const std::vector<cv::Mat>& costs, const cv::Mat& first_plane,
                            int stride) {
  CV_Assert(!costs.empty());
  const cv::Size size = costs[0].size();
  PlaneSelection selection;
  selection.plane.create(size, CV_32FC1);
  selection.confidence.create(size, CV_32FC1);
  selection.at_edge.create(size, CV_8UC1);
  SelectPlanesInto(costs, first_plane, stride, &selection);
  return selection;
}

void SelectPlanesInto(const std::vector<cv::Mat>& costs, const cv::Mat& first_plane, int stride,
                      PlaneSelection* out) {
  SelectPlanesNearSeedInto(costs, first_plane, stride, {}, out);
}

void SelectPlanesNearSeedInto(const std::vector<cv::Mat>& costs, const cv::Mat& first_plane,
                              int stride, const SeedPrior& prior, PlaneSelection* out) {
  CV_Assert(!costs.empty());
  const int n = static_cast<int>(costs.size());
  const cv::Size size = costs[0].size();
  CV_Assert(out->plane.size() == size && out->plane.type() == CV_32FC1);
  CV_Assert(out->confidence.size() == size && out->confidence.type() == CV_32FC1);
  CV_Assert(out->at_edge.size() == size && out->at_edge.type() == CV_8UC1);
  CV_Assert(first_plane.empty() || (first_plane.size() == size && first_plane.type() == CV_32SC1));
  const bool with_prior = prior.weight > 0.0f;
  CV_Assert(prior.weight >= 0.0f && stride >= 1);
  CV_Assert(!with_prior || (prior.seed.size() == size && prior.seed.type() == CV_32FC1));
  PlaneSelection& selection = *out;
  cv::parallel_for_(cv::Range(0, size.height), [&](const cv::Range& rows) {
    std::vector<const float*> slice(n);
    std::vector<float> curve(n);
    for (int y = rows.start; y < rows.end; ++y) {
      for (int k = 0; k < n; ++k) slice[k] = costs[k].ptr<float>(y);
      const int* first = first_plane.empty() ? nullptr : first_plane.ptr<int>(y);
      const float* seed = with_prior ? prior.seed.ptr<float>(y) : nullptr;
      float* plane = selection.plane.ptr<float>(y);
      float* confidence = selection.confidence.ptr<float>(y);
      uchar* at_edge = selection.at_edge.ptr<uchar>(y);
      for (int x = 0; x < size.width; ++x) {
        for (int k = 0; k < n; ++k) curve[k] = slice[k][x];
        if (!with_prior) {
          SelectCurve(curve.data(), n, first ? first[x] : 0, stride, &plane[x], &confidence[x],
                      &at_edge[x]);
          continue;
        }
        // The edge flag of the photo-consistency alone.
        const uchar raw_edge = EdgeFlag(curve.data(), n, LowestSlice(curve.data(), n));
        const float seed_slice = (seed[x] - (first ? first[x] : 0)) / stride;
        for (int k = 0; k < n; ++k) {
          const float offset = k - seed_slice;
          if (curve[k] < kNoCost) curve[k] += prior.weight * offset * offset;
        }
        SelectCurve(curve.data(), n, first ? first[x] : 0, stride, &plane[x], &confidence[x],
                    &at_edge[x]);
        at_edge[x] = raw_edge;
      }
    }
  });
}

cv::Mat ConfidenceOfPlanes(const std::vector<cv::Mat>& costs, const cv::Mat& plane, int reach,
                           cv::Mat* valley_cost) {
  CV_Assert(reach >= 0);
  CV_Assert(!costs.empty() && plane.type() == CV_32FC1 && plane.size() == costs[0].size());
  const int n = static_cast<int>(costs.size());
  cv::Mat confidence(plane.size(), CV_32FC1);
  if (valley_cost) valley_cost->create(plane.size(), CV_32FC1);
  cv::parallel_for_(cv::Range(0, plane.rows), [&](const cv::Range& rows) {
    std::vector<float> curve(n);
    for (int y = rows.start; y < rows.end; ++y) {
      const float* p = plane.ptr<float>(y);
      float* c = confidence.ptr<float>(y);
      float* v = valley_cost ? valley_cost->ptr<float>(y) : nullptr;
      for (int x = 0; x < plane.cols; ++x) {
        const int best = static_cast<int>(std::lround(p[x]));
        if (v) v[x] = kNoCost;
        if (p[x] < 0.0f || best >= n) {
          c[x] = 0.0f;
          continue;
        }
        for (int k = 0; k < n; ++k) curve[k] = costs[k].ptr<float>(y)[x];
        // Down the curve to the minimum whose valley holds the winner.
        int minimum = best;
        while (true) {
          const float here = curve[minimum];
          if (minimum > 0 && curve[minimum - 1] < here &&
              (minimum == n - 1 || curve[minimum - 1] <= curve[minimum + 1]))
            --minimum;
          else if (minimum < n - 1 && curve[minimum + 1] < here)
            ++minimum;
          else
            break;
        }
        const bool found = curve[minimum] < kNoCost && std::abs(minimum - best) <= reach;
        c[x] = found ? std::max(0.0f, Distinctiveness(curve.data(), n, minimum)) : 0.0f;
        if (v && found) v[x] = curve[minimum];
      }
    }
  });
  return confidence;
}

int RejectCostOutliers(const cv::Mat& cost, const cv::Mat& reference, int window_radius,
                       double max_ratio, cv::Mat* confidence, cv::Mat* rejected) {
  CV_Assert(cost.type() == CV_32FC1 && confidence->type() == CV_32FC1 &&
            reference.type() == CV_32FC1 && cost.size() == confidence->size() &&
            cost.size() == reference.size() && max_ratio > 0.0 && window_radius >= 0);
  // Texture: the mean gradient magnitude over the cost's window.
  cv::Mat gx, gy, texture;
  cv::Sobel(reference, gx, CV_32F, 1, 0, 3, 1.0, 0.0, cv::BORDER_REPLICATE);
  cv::Sobel(reference, gy, CV_32F, 0, 1, 3, 1.0, 0.0, cv::BORDER_REPLICATE);
  texture = cv::abs(gx) + cv::abs(gy);
  const int side = 2 * window_radius + 1;
  cv::boxFilter(texture, texture, -1, cv::Size(side, side), cv::Point(-1, -1), true,
                cv::BORDER_REPLICATE);
  // Pixels with a cost, ordered by texture, in classes of equal size.
  std::vector<std::pair<float, int>> order;
  order.reserve(cost.total());
  const float* c_all = cost.ptr<float>(0);
  const float* t_all = texture.ptr<float>(0);
  CV_Assert(cost.isContinuous() && texture.isContinuous() && confidence->isContinuous());
  for (int i = 0; i < static_cast<int>(cost.total()); ++i)
    if (c_all[i] < kNoCost) order.emplace_back(t_all[i], i);
  if (order.empty()) return 0;
  std::sort(order.begin(), order.end());
  float* conf = confidence->ptr<float>(0);
  uchar* mask = nullptr;
  if (rejected) {
    rejected->create(cost.size(), CV_8UC1);
    rejected->setTo(0);
    mask = rejected->ptr<uchar>(0);
  }
  const size_t classes = std::min<size_t>(kTextureClasses, order.size());
  int count = 0;
  std::vector<float> costs;
  for (size_t k = 0; k < classes; ++k) {
    const size_t begin = order.size() * k / classes, end = order.size() * (k + 1) / classes;
    costs.clear();
    for (size_t j = begin; j < end; ++j) costs.push_back(c_all[order[j].second]);
    std::nth_element(costs.begin(), costs.begin() + costs.size() / 2, costs.end());
    const float limit =
        static_cast<float>(max_ratio) * std::max(costs[costs.size() / 2], kMinOutlierCostScale);
    for (size_t j = begin; j < end; ++j) {
      const int i = order[j].second;
      if (c_all[i] > limit && conf[i] > 0.0f) {
        conf[i] = 0.0f;
        if (mask) mask[i] = 255;
        ++count;
      }
    }
  }
  return count;
}

}  // namespace dfsm
