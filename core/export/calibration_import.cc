#include "core/export/calibration_import.h"

#include <Eigen/Dense>
#include <cmath>
#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <sstream>
#include <system_error>

#include "core/io/bounded_json.h"
#include "core/io/file_util.h"

namespace dfsm {

namespace {

using nlohmann::json;

// Far above any calibration; bounds what a wrong path makes us read and parse.
constexpr std::uintmax_t kMaxFileBytes = 1 << 20;
// A grid pixel whose undistorted point does not project back this close has
// none: OpenCV's iteration returns the distorted point when it diverges.
constexpr double kMaxRoundTripPx = 1e-6;

std::string Str(double value) {
  if (std::isnan(value)) return "nan";  // not the platform's "-nan"
  std::ostringstream out;
  out << value;
  return out.str();
}

std::string Size(int width, int height) { return Str(width) + " x " + Str(height); }

void CheckIntrinsics(int width, int height, double fx, double fy, double cx, double cy) {
  if (width <= 0 || height <= 0)
    throw CalibrationFileError("image size " + Size(width, height) + " is not positive");
  if (!std::isfinite(fx) || !std::isfinite(fy) || !(fx > 0) || !(fy > 0))
    throw CalibrationFileError("focal length fx " + Str(fx) + ", fy " + Str(fy) +
                               " is not a positive finite number");
  if (!(cx >= 0 && cx <= width && cy >= 0 && cy <= height))
    throw CalibrationFileError("principal point (" + Str(cx) + ", " + Str(cy) +
                               ") lies outside the " + Size(width, height) + " image");
}

void NoteNonSquarePixels(double fx, double fy, ImportedCalibration* result) {
  if (fx == fy) return;
  const double percent = std::round(std::abs(fx - fy) / ((fx + fy) / 2) * 1e4) / 100;
  result->notes.push_back("fx " + Str(fx) + " and fy " + Str(fy) + " differ by " + Str(percent) +
                          " %: f is their mean");
}

// The calibration as one file holds it, before it is checked and converted.
struct FileFields {
  std::string format;
  int width = 0, height = 0;  // 0: the file names no size
  double fx = 0, fy = 0, cx = 0, cy = 0;
  bool native = false;  // k1, k2 are ha2016-d2u; otherwise `distortion` is OpenCV's
  double k1 = 0, k2 = 0;
  std::vector<double> distortion;
};

const json* Find(const json& object, const std::string& key) {
  const auto it = object.find(key);
  return it == object.end() ? nullptr : &*it;
}

const json& Require(const json& object, const std::string& key) {
  const json* value = Find(object, key);
  if (value == nullptr) throw CalibrationFileError("it has no " + key);
  return *value;
}

double Number(const json& value, const std::string& what) {
  if (!value.is_number())
    throw CalibrationFileError(what + " is " + DescribeJsonValue(value) + ", not a number");
  const double number = value.get<double>();
  if (!std::isfinite(number))
    throw CalibrationFileError(what + " is " + Str(number) + ", not a finite number");
  return number;
}

int Integer(const json& value, const std::string& what) {
  const double number = Number(value, what);
  if (number != std::floor(number) || std::abs(number) > 1e9)
    throw CalibrationFileError(what + " is " + Str(number) + ", not an integer");
  return static_cast<int>(number);
}

std::string String(const json& value, const std::string& what) {
  if (!value.is_string())
    throw CalibrationFileError(what + " is " + DescribeJsonValue(value) + ", not a string");
  return value.get<std::string>();
}

// A matrix as OpenCV ({rows, cols, dt, data}), ROS ({rows, cols, data}) or a
// bare list writes it; returns its values row-major, checking declared shapes.
std::vector<double> Matrix(const json& object, const std::string& key, int rows, int cols) {
  const json& node = Require(object, key);
  const json& data = node.is_object() ? Require(node, "data") : node;
  std::vector<double> values;
  if (data.is_number()) values.push_back(Number(data, key + ".data"));  // OpenCV's 1x1
  if (!data.is_number() && !data.is_array())
    throw CalibrationFileError(key + " is " + DescribeJsonValue(data) + ", not a list of numbers");
  for (size_t i = 0; data.is_array() && i < data.size(); ++i)
    values.push_back(Number(data[i], key + ".data[" + std::to_string(i) + "]"));
  const int file_rows = node.contains("rows") ? Integer(node["rows"], key + ".rows") : rows;
  const int file_cols = node.contains("cols") ? Integer(node["cols"], key + ".cols") : cols;
  if (rows > 0 && (file_rows != rows || file_cols != cols))
    throw CalibrationFileError(key + " is " + Str(file_rows) + "x" + Str(file_cols) + ", not " +
                               Str(rows) + "x" + Str(cols));
  if (file_rows > 0 && file_cols > 0 && values.size() != size_t(file_rows) * file_cols)
    throw CalibrationFileError(key + " is " + Str(file_rows) + "x" + Str(file_cols) +
                               " but holds " + Str(values.size()) + " values");
  return values;
}

// image_width/image_height, or width/height inside dfsm's native object.
void ReadSize(const json& object, const char* width_key, const char* height_key, FileFields* f) {
  const bool has_width = object.contains(width_key), has_height = object.contains(height_key);
  if (has_width != has_height)
    throw CalibrationFileError(std::string("it names ") + (has_width ? width_key : height_key) +
                               " but not " + (has_width ? height_key : width_key));
  if (!has_width) return;
  f->width = Integer(object[width_key], width_key);
  f->height = Integer(object[height_key], height_key);
  if (f->width <= 0 || f->height <= 0)
    throw CalibrationFileError("image size " + Size(f->width, f->height) + " is not positive");
}

void ReadCameraMatrix(const json& object, FileFields* f) {
  const std::vector<double> K = Matrix(object, "camera_matrix", 3, 3);
  if (K.size() != 9)
    throw CalibrationFileError("camera_matrix holds " + Str(K.size()) + " values, not 9");
  // Skew and a non-unit last row have no place in a square-pixel pinhole.
  if (std::abs(K[1]) > 1e-6 * std::abs(K[0]) || K[3] != 0 || K[6] != 0 || K[7] != 0 || K[8] != 1)
    throw CalibrationFileError("camera_matrix is not of the form [fx 0 cx; 0 fy cy; 0 0 1]");
  f->fx = K[0], f->fy = K[4], f->cx = K[2], f->cy = K[5];
}

void RequireNativeModel(const std::string& model) {
  if (model != kDistortionModelName)
    throw CalibrationFileError("native distortion model '" + model + "' is not '" +
                               kDistortionModelName + "'");
}

FileFields ReadFields(const json& doc, const std::string& syntax) {
  if (!doc.is_object())
    throw CalibrationFileError("it holds " + DescribeJsonValue(doc) + ", not calibration fields");
  FileFields f;
  if (const json* native = Find(doc, "native")) {  // dfsm's calibration.json
    if (!native->is_object())
      throw CalibrationFileError("native is " + DescribeJsonValue(*native) + ", not an object");
    f.format = "dfsm-json";
    f.native = true;
    const auto field = [&](const char* key) {
      return Number(Require(*native, key), std::string("native.") + key);
    };
    if (native->contains("distortion_model"))
      RequireNativeModel(String((*native)["distortion_model"], "native.distortion_model"));
    ReadSize(*native, "width", "height", &f);
    f.fx = field("fx");
    f.fy = native->contains("fy") ? field("fy") : f.fx;
    f.cx = field("cx"), f.cy = field("cy"), f.k1 = field("k1"), f.k2 = field("k2");
    return f;
  }
  ReadSize(doc, "image_width", "image_height", &f);
  ReadCameraMatrix(doc, &f);
  if (const json* model = Find(doc, "native_model")) {  // dfsm's calibration.yaml
    f.format = "dfsm-yaml";
    f.native = true;
    RequireNativeModel(String(*model, "native_model"));
    f.k1 = Number(Require(doc, "native_k1"), "native_k1");
    f.k2 = Number(Require(doc, "native_k2"), "native_k2");
    return f;
  }
  f.format = "opencv-" + syntax;
  std::string model;  // ROS CameraInfo names its distortion model, OpenCV's files do not
  size_t expected = 0;
  if (doc.contains("distortion_model")) {
    f.format = "ros-camera-info";
    model = String(doc["distortion_model"], "distortion_model");
    expected = model == "plumb_bob" ? 5 : model == "rational_polynomial" ? 8 : 0;
    if (expected == 0)
      throw CalibrationFileError("distortion_model '" + model +
                                 "' is unknown (known: plumb_bob, rational_polynomial)");
  }
  f.distortion = Matrix(doc, "distortion_coefficients", 0, 0);
  if (expected != 0 && f.distortion.size() != expected)
    throw CalibrationFileError("distortion_coefficients holds " + Str(f.distortion.size()) +
                               " values, but " + model + " has " + Str(expected));
  return f;
}

// JSON by nlohmann; YAML and XML by OpenCV, converted to the same tree.
json FileNodeToJson(const cv::FileNode& node, int depth) {
  if (depth > kMaxJsonDepth)
    throw CalibrationFileError("nested deeper than " + Str(kMaxJsonDepth) + " levels");
  if (node.isMap() || node.isSeq()) {
    json out = node.isMap() ? json::object() : json::array();
    for (const cv::FileNode& child : node) {
      if (node.isMap())
        out[child.name()] = FileNodeToJson(child, depth + 1);
      else
        out.push_back(FileNodeToJson(child, depth + 1));
    }
    return out;
  }
  if (node.isInt()) return static_cast<int>(node);
  if (node.isReal()) return static_cast<double>(node);
  if (node.isString()) return static_cast<std::string>(node);
  return nullptr;
}

json ParseText(const std::string& text, std::string* syntax) {
  if (text.find('\0') != std::string::npos)
    throw CalibrationFileError("it is not a text file (it holds NUL bytes)");
  const size_t start = text.find_first_not_of(" \t\r\n");
  if (start == std::string::npos) throw CalibrationFileError("it is empty");
  if (text[start] == '{') {
    *syntax = "json";
    try {
      return ParseBoundedJson(text);
    } catch (const JsonInputError& e) {
      throw CalibrationFileError(e.what());
    }
  }
  *syntax = text[start] == '<' ? "xml" : "yaml";
  // OpenCV recognises YAML only by a leading %YAML directive, which ROS's
  // CameraInfo files (and most hand-written YAML) lack.
  const bool add_directive = *syntax == "yaml" && text.compare(0, 5, "%YAML") != 0;
  try {
    cv::FileStorage storage(add_directive ? "%YAML:1.0\n" + text : text,
                            cv::FileStorage::READ | cv::FileStorage::MEMORY);
    if (!storage.isOpened()) throw CalibrationFileError("OpenCV cannot open it");
    return FileNodeToJson(storage.root(), 0);
  } catch (const cv::Exception& e) {
    throw CalibrationFileError("it is not " + std::string(*syntax == "xml" ? "XML" : "YAML") +
                               " that OpenCV can read (" + e.err + ")");
  }
}

ImportedCalibration Convert(const FileFields& f, int width, int height) {
  if (f.width > 0 && width > 0 && height > 0 && (f.width != width || f.height != height))
    throw CalibrationFileError("it is for " + Size(f.width, f.height) + " images, the burst is " +
                               Size(width, height));
  if (f.width == 0 && (width <= 0 || height <= 0))
    throw CalibrationFileError("it names no image size (image_width, image_height)");
  if (f.width > 0) width = f.width, height = f.height;
  if (!f.native) return FitOpenCvCalibration(width, height, f.fx, f.fy, f.cx, f.cy, f.distortion);
  CheckIntrinsics(width, height, f.fx, f.fy, f.cx, f.cy);
  ImportedCalibration result;
  result.camera = CameraModel{width, height, (f.fx + f.fy) / 2, f.cx, f.cy, f.k1, f.k2};
  NoteNonSquarePixels(f.fx, f.fy, &result);
  return result;
}

}  // namespace

ImportedCalibration ReadCalibrationFile(const std::filesystem::path& path, int width, int height) {
  try {
    std::error_code error;
    const auto status = std::filesystem::status(path, error);
    if (status.type() == std::filesystem::file_type::not_found)
      throw CalibrationFileError("no such file");
    if (error) throw CalibrationFileError("cannot read it (" + error.message() + ")");
    if (!std::filesystem::is_regular_file(status))
      throw CalibrationFileError("it is not a regular file");
    const std::uintmax_t bytes = std::filesystem::file_size(path, error);
    if (!error && bytes > kMaxFileBytes)
      throw CalibrationFileError("it is " + Str(bytes) + " bytes, more than any calibration");
    std::string syntax;
    const json doc = ParseText(ReadFileToString(path), &syntax);
    const FileFields fields = ReadFields(doc, syntax);
    ImportedCalibration result = Convert(fields, width, height);
    result.format = fields.format;
    return result;
  } catch (const std::exception& e) {
    // CalibrationFileError from the checks above; ReadFileToString's,
    // OpenCV's and nlohmann's own types must not escape as themselves.
    throw CalibrationFileError("calibration file " + path.string() + ": " + e.what());
  }
}

ImportedCalibration FitOpenCvCalibration(int width, int height, double fx, double fy, double cx,
                                         double cy, const std::vector<double>& distortion) {
  CheckIntrinsics(width, height, fx, fy, cx, cy);
  const size_t n = distortion.size();
  if (n != 0 && n != 4 && n != 5 && n != 8)
    throw CalibrationFileError(
        "OpenCV's distortion takes 4, 5 or 8 coefficients (k1 k2 p1 p2 "
        "[k3 [k4 k5 k6]]), not " +
        Str(n));
  for (size_t i = 0; i < n; ++i)
    if (!std::isfinite(distortion[i]))
      throw CalibrationFileError("distortion coefficient " + Str(i) + " is " + Str(distortion[i]) +
                                 ", not a finite number");
  ImportedCalibration result;
  const double f = (fx + fy) / 2;
  result.camera = CameraModel{width, height, f, cx, cy, 0.0, 0.0};
  NoteNonSquarePixels(fx, fy, &result);

  // A dense grid over the captured image, corners included: the fit must hold
  // where the distortion is largest.
  constexpr int kSteps = 48;
  std::vector<cv::Point2d> pixels;
  for (int iy = 0; iy <= kSteps; ++iy)
    for (int ix = 0; ix <= kSteps; ++ix)
      pixels.emplace_back(width * ix / double(kSteps), height * iy / double(kSteps));
  const cv::Matx33d K(fx, 0, cx, 0, fy, cy, 0, 0, 1);
  // OpenCV's default stops after 5 iterations, far from converged where the
  // distortion is strong.
  std::vector<cv::Point2d> undistorted, round_trip;
  cv::undistortPoints(
      pixels, undistorted, K, distortion, cv::noArray(), cv::noArray(),
      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 100, 1e-12));
  std::vector<cv::Point3d> rays;
  for (const cv::Point2d& x : undistorted) rays.emplace_back(x.x, x.y, 1.0);
  cv::projectPoints(rays, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, distortion, round_trip);

  std::vector<Eigen::Vector2d> x_d, x_u;
  for (size_t i = 0; i < pixels.size(); ++i) {
    if (!(cv::norm(round_trip[i] - pixels[i]) <= kMaxRoundTripPx)) continue;
    x_d.emplace_back((pixels[i].x - cx) / f, (pixels[i].y - cy) / f);
    x_u.emplace_back(undistorted[i].x, undistorted[i].y);
  }
  const size_t failed = pixels.size() - x_d.size();
  if (failed > pixels.size() / 2)
    throw CalibrationFileError("OpenCV's distortion cannot be inverted at " + Str(failed) + " of " +
                               Str(pixels.size()) + " grid pixels: it folds the image over");
  if (failed > 0)
    result.notes.push_back(Str(failed) + " of " + Str(pixels.size()) +
                           " grid pixels have no undistorted point in the file's model (it folds "
                           "over there) and are left out of the fit");

  // x_u = x_d (1 + k1 r^2 + k2 r^4), both coordinates, residual scaled by f
  // into pixels so the error reported is what a user sees in the image.
  Eigen::MatrixXd A(2 * x_d.size(), 2);
  Eigen::VectorXd b(2 * x_d.size());
  for (size_t i = 0; i < x_d.size(); ++i) {
    const double r2 = x_d[i].squaredNorm();
    for (int c = 0; c < 2; ++c) {
      A.row(2 * i + c) << f * x_d[i][c] * r2, f * x_d[i][c] * r2 * r2;
      b[2 * i + c] = f * (x_u[i][c] - x_d[i][c]);
    }
  }
  const Eigen::Vector2d k = A.colPivHouseholderQr().solve(b);
  result.camera.k1 = k[0], result.camera.k2 = k[1];
  const Eigen::VectorXd residual = A * k - b;
  double sum_sq = 0.0;
  for (size_t i = 0; i < x_d.size(); ++i) {
    const double error_sq = residual.segment<2>(2 * i).squaredNorm();
    result.fit_max_error_px = std::max(result.fit_max_error_px, std::sqrt(error_sq));
    sum_sq += error_sq;
  }
  result.fit_rms_error_px = std::sqrt(sum_sq / x_d.size());
  if (result.fit_max_error_px > 0.5)
    result.notes.push_back(std::string(kDistortionModelName) + " follows the file's model to " +
                           Str(result.fit_max_error_px) + " px at worst, " +
                           Str(result.fit_rms_error_px) + " px RMS, over the image");

  const double p1 = n >= 4 ? distortion[2] : 0.0, p2 = n >= 4 ? distortion[3] : 0.0;
  if (p1 != 0 || p2 != 0) {
    double tangential_px = 0.0;  // OpenCV's tangential term alone, at the grid
    for (const Eigen::Vector2d& x : x_u) {
      const double xy = x.x() * x.y(), r2 = x.squaredNorm();
      tangential_px =
          std::max(tangential_px, std::hypot(fx * (2 * p1 * xy + p2 * (r2 + 2 * x.x() * x.x())),
                                             fy * (p1 * (r2 + 2 * x.y() * x.y()) + 2 * p2 * xy)));
    }
    result.notes.push_back("tangential distortion p1 " + Str(p1) + ", p2 " + Str(p2) +
                           " has no place in " + kDistortionModelName +
                           "; it moves pixels by up to " + Str(tangential_px) +
                           " px and is part of the fit error");
  }
  if (result.fit_max_error_px >= kMinResampledFitErrorPx) {
    result.lens = OpenCvLens{fx, fy, cx, cy, distortion};
    result.notes.push_back("the frames are resampled from the file's model onto the " +
                           std::string(kDistortionModelName) +
                           " fit, so that the fit error does not misplace them");
  }
  return result;
}

}  // namespace dfsm
