#include "core/export/calibration_import.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <iostream>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "core/export/calibration_export.h"
#include "core/io/file_util.h"

namespace dfsm {
namespace {

namespace fs = std::filesystem;

fs::path TestDir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("dfsm_calibration_import_test_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

void ExpectRelative(double actual, double expected, double tolerance) {
  EXPECT_NEAR(actual, expected, tolerance * std::abs(expected));
}

TEST(CalibrationImport, RoundTripsDfsmFilesThroughTheNativeCoefficients) {
  CameraModel camera = CameraModel::Initial(1280, 720);
  camera.f = 1043.7;
  camera.cx = 652.25;
  camera.cy = 351.5;
  camera.k1 = -0.12;
  camera.k2 = 0.05;
  const fs::path dir = TestDir("round_trip");
  WriteCalibrationFiles(dir, camera);
  for (const char* name : {"calibration.json", "calibration.yaml"}) {
    SCOPED_TRACE(name);
    const ImportedCalibration imported = ReadCalibrationFile(dir / name, 1280, 720);
    EXPECT_EQ(imported.format, name == std::string("calibration.json") ? "dfsm-json" : "dfsm-yaml");
    EXPECT_EQ(imported.camera.width, 1280);
    EXPECT_EQ(imported.camera.height, 720);
    ExpectRelative(imported.camera.f, camera.f, 1e-9);
    ExpectRelative(imported.camera.cx, camera.cx, 1e-9);
    ExpectRelative(imported.camera.cy, camera.cy, 1e-9);
    ExpectRelative(imported.camera.k1, camera.k1, 1e-9);
    ExpectRelative(imported.camera.k2, camera.k2, 1e-9);
    EXPECT_EQ(imported.fit_max_error_px, 0.0);
    EXPECT_TRUE(imported.notes.empty());
    EXPECT_FALSE(imported.lens.has_value());  // the frames follow the camera as they are
  }
}

// TUM RGB-D freiburg1, the published OpenCV calibration of a 640x480 Kinect.
constexpr double kFx = 517.3, kFy = 516.5, kCx = 318.6, kCy = 255.3;
const std::vector<double> kTumDistortion = {0.2624, -0.9531, -0.0054, 0.0026, 1.1633};

void WriteOpenCvFile(const fs::path& path, bool with_size) {
  cv::FileStorage out(path.string(), cv::FileStorage::WRITE);
  if (with_size) out << "image_width" << 640 << "image_height" << 480;
  out << "camera_matrix" << cv::Mat(cv::Matx33d(kFx, 0, kCx, 0, kFy, kCy, 0, 0, 1));
  out << "distortion_coefficients" << cv::Mat(kTumDistortion).reshape(1, 1);
}

// As ROS's camera_calibration_parsers writes it: no %YAML directive, flow lists.
const char* kTumRosYaml = R"(image_width: 640
image_height: 480
camera_name: freiburg1_rgb
camera_matrix:
  rows: 3
  cols: 3
  data: [517.3, 0, 318.6, 0, 516.5, 255.3, 0, 0, 1]
distortion_model: plumb_bob
distortion_coefficients:
  rows: 1
  cols: 5
  data: [0.2624, -0.9531, -0.0054, 0.0026, 1.1633]
rectification_matrix:
  rows: 3
  cols: 3
  data: [1, 0, 0, 0, 1, 0, 0, 0, 1]
projection_matrix:
  rows: 3
  cols: 4
  data: [517.3, 0, 318.6, 0, 0, 516.5, 255.3, 0, 0, 0, 1, 0]
)";

std::string Replace(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return at == std::string::npos ? text : text.replace(at, from.size(), to);
}

void ExpectSameCamera(const ImportedCalibration& a, const ImportedCalibration& b) {
  EXPECT_EQ(a.camera.width, b.camera.width);
  EXPECT_EQ(a.camera.height, b.camera.height);
  EXPECT_NEAR(a.camera.f, b.camera.f, 1e-12);
  EXPECT_NEAR(a.camera.cx, b.camera.cx, 1e-12);
  EXPECT_NEAR(a.camera.cy, b.camera.cy, 1e-12);
  EXPECT_NEAR(a.camera.k1, b.camera.k1, 1e-12);
  EXPECT_NEAR(a.camera.k2, b.camera.k2, 1e-12);
  EXPECT_NEAR(a.fit_max_error_px, b.fit_max_error_px, 1e-9);
  EXPECT_NEAR(a.fit_rms_error_px, b.fit_rms_error_px, 1e-9);
}

bool Mentions(const std::vector<std::string>& notes, const std::string& text) {
  for (const std::string& note : notes)
    if (note.find(text) != std::string::npos) return true;
  return false;
}

TEST(CalibrationImport, FitsTheTumFreiburg1Calibration) {
  const fs::path dir = TestDir("tum");
  WriteOpenCvFile(dir / "opencv.yaml", true);
  WriteOpenCvFile(dir / "opencv.xml", false);
  WriteFileAtomically(dir / "ros.yaml", std::string(kTumRosYaml));
  const ImportedCalibration opencv = ReadCalibrationFile(dir / "opencv.yaml", 640, 480);
  const ImportedCalibration xml = ReadCalibrationFile(dir / "opencv.xml", 640, 480);
  const ImportedCalibration ros = ReadCalibrationFile(dir / "ros.yaml", 640, 480);
  const ImportedCalibration fit =
      FitOpenCvCalibration(640, 480, kFx, kFy, kCx, kCy, kTumDistortion);
  EXPECT_EQ(opencv.format, "opencv-yaml");
  EXPECT_EQ(xml.format, "opencv-xml");
  EXPECT_EQ(ros.format, "ros-camera-info");
  ExpectSameCamera(opencv, fit);
  ExpectSameCamera(xml, fit);
  ExpectSameCamera(ros, fit);
  EXPECT_DOUBLE_EQ(fit.camera.f, (kFx + kFy) / 2);
  EXPECT_EQ(fit.camera.cx, kCx);
  EXPECT_EQ(fit.camera.cy, kCy);
  EXPECT_TRUE(Mentions(ros.notes, "fx 517.3 and fy 516.5 differ by 0.15 %"));
  EXPECT_TRUE(Mentions(ros.notes, "tangential distortion p1 -0.0054, p2 0.0026"));
  // The fit misses by pixels: the file's own lens comes with it, for the
  // frames to be resampled from.
  ASSERT_TRUE(fit.lens.has_value());
  EXPECT_EQ(fit.lens->fx, kFx);
  EXPECT_EQ(fit.lens->fy, kFy);
  EXPECT_EQ(fit.lens->cx, kCx);
  EXPECT_EQ(fit.lens->cy, kCy);
  EXPECT_EQ(fit.lens->distortion, kTumDistortion);
  EXPECT_TRUE(Mentions(ros.notes, "the frames are resampled from the file's model"));
  std::cout << "TUM freiburg1 -> ha2016-d2u: f " << fit.camera.f << " k1 " << fit.camera.k1
            << " k2 " << fit.camera.k2 << ", fit error max " << fit.fit_max_error_px << " px, rms "
            << fit.fit_rms_error_px << " px\n";
  for (const std::string& note : fit.notes) std::cout << "  note: " << note << "\n";
  RecordProperty("tum_k1", std::to_string(fit.camera.k1));
  RecordProperty("tum_k2", std::to_string(fit.camera.k2));
  RecordProperty("tum_fit_max_error_px", std::to_string(fit.fit_max_error_px));

  // Independent check on a grid other than the fit's: OpenCV's own inverse
  // against the fitted model, in pixels at the fitted focal length.
  std::vector<cv::Point2d> pixels;
  for (double v = 0; v <= 480; v += 20)
    for (double u = 0; u <= 640; u += 20) pixels.emplace_back(u, v);
  std::vector<cv::Point2d> truth;
  cv::undistortPoints(
      pixels, truth, cv::Matx33d(kFx, 0, kCx, 0, kFy, kCy, 0, 0, 1), kTumDistortion, cv::noArray(),
      cv::noArray(), cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 100, 1e-12));
  double worst_fitted = 0.0, sum_sq_fitted = 0.0, sum_sq_plain = 0.0;
  CameraModel no_distortion = fit.camera;
  no_distortion.k1 = no_distortion.k2 = 0.0;
  for (size_t i = 0; i < pixels.size(); ++i) {
    const Eigen::Vector2d pixel(pixels[i].x, pixels[i].y), x_true(truth[i].x, truth[i].y);
    const double fitted = fit.camera.f * (fit.camera.PixelToUndistorted(pixel) - x_true).norm();
    const double plain = fit.camera.f * (no_distortion.PixelToUndistorted(pixel) - x_true).norm();
    worst_fitted = std::max(worst_fitted, fitted);
    sum_sq_fitted += fitted * fitted;
    sum_sq_plain += plain * plain;
  }
  const double rms_fitted = std::sqrt(sum_sq_fitted / pixels.size());
  const double rms_plain = std::sqrt(sum_sq_plain / pixels.size());
  std::cout << "  independent grid: fitted model max " << worst_fitted << " px, RMS " << rms_fitted
            << " px; without distortion RMS " << rms_plain << " px\n";
  EXPECT_LE(worst_fitted, fit.fit_max_error_px + 1e-9);
  EXPECT_NEAR(rms_fitted, fit.fit_rms_error_px, 0.25 * fit.fit_rms_error_px);
  // Two radial terms cannot follow this calibration's k3 into the corners
  // (about 11 px there), but over the image they remove most of its distortion.
  EXPECT_LT(rms_fitted, 0.3 * rms_plain);
}

TEST(CalibrationImport, RecoversAHa2016CameraFromItsOpenCvFit) {
  CameraModel camera = CameraModel::Initial(1920, 1080);
  camera.f = 1650.0;
  camera.cx = 947.0;
  camera.cy = 551.0;
  camera.k1 = -0.09;
  camera.k2 = 0.03;
  const OpenCvDistortionFit opencv = FitOpenCvDistortion(camera);
  const ImportedCalibration back =
      FitOpenCvCalibration(1920, 1080, camera.f, camera.f, camera.cx, camera.cy,
                           {opencv.k1, opencv.k2, 0, 0, opencv.k3});
  std::cout << "ha2016-d2u k1 -0.09 k2 0.03 -> OpenCV -> k1 " << back.camera.k1 << " k2 "
            << back.camera.k2 << ", fit error max " << back.fit_max_error_px << " px\n";
  EXPECT_EQ(back.camera.f, camera.f);
  EXPECT_NEAR(back.camera.k1, camera.k1, 1e-4);
  EXPECT_NEAR(back.camera.k2, camera.k2, 1e-4);
  EXPECT_LT(back.fit_max_error_px, 0.05);
  EXPECT_TRUE(back.notes.empty());
  EXPECT_FALSE(back.lens.has_value());  // the fit holds it: nothing to resample
}

TEST(CalibrationImport, ReadsRosRationalPolynomialAndNoDistortion) {
  const fs::path dir = TestDir("rational");
  std::string rational = Replace(kTumRosYaml, "plumb_bob", "rational_polynomial");
  rational = Replace(rational, "cols: 5\n  data: [0.2624, -0.9531, -0.0054, 0.0026, 1.1633]",
                     "cols: 8\n  data: [0.2624, -0.9531, -0.0054, 0.0026, 1.1633, 0, 0, 0]");
  WriteFileAtomically(dir / "rational.yaml", rational);
  ExpectSameCamera(ReadCalibrationFile(dir / "rational.yaml", 640, 480),
                   FitOpenCvCalibration(640, 480, kFx, kFy, kCx, kCy, kTumDistortion));

  const ImportedCalibration plain = FitOpenCvCalibration(640, 480, 500, 500, 320, 240, {});
  EXPECT_NEAR(plain.camera.k1, 0.0, 1e-12);
  EXPECT_NEAR(plain.camera.k2, 0.0, 1e-12);
  EXPECT_LT(plain.fit_max_error_px, 1e-9);
  EXPECT_TRUE(plain.notes.empty());
  EXPECT_FALSE(plain.lens.has_value());
}

TEST(CalibrationImport, UsesTheBurstSizeWhenTheFileNamesNone) {
  const fs::path dir = TestDir("no_size");
  WriteOpenCvFile(dir / "opencv.yaml", false);
  const ImportedCalibration imported = ReadCalibrationFile(dir / "opencv.yaml", 640, 480);
  EXPECT_EQ(imported.camera.width, 640);
  EXPECT_EQ(imported.camera.height, 480);
  EXPECT_THROW(ReadCalibrationFile(dir / "opencv.yaml", 0, 0), CalibrationFileError);
}

// Reads `content` as a file and returns the error's message ("" if none).
std::string ErrorOf(const fs::path& path, const std::string& content, int width = 640,
                    int height = 480) {
  WriteFileAtomically(path, content);
  try {
    ReadCalibrationFile(path, width, height);
  } catch (const CalibrationFileError& e) {
    return e.what();
  }
  return "";
}

TEST(CalibrationImport, RefusesMalformedFilesWithTheFileAndTheProblem) {
  const fs::path dir = TestDir("malformed");
  const fs::path path = dir / "calibration.yaml";
  const std::string ros = kTumRosYaml;
  const std::string k = "data: [517.3, 0, 318.6, 0, 516.5, 255.3, 0, 0, 1]";
  const std::string d = "data: [0.2624, -0.9531, -0.0054, 0.0026, 1.1633]";
  const struct {
    std::string content, problem;
  } cases[] = {
      {std::string("\x89PNG\0\0", 6), "not a text file"},
      {"camera_matrix: [1, 2\n  : : ]]\n", "not YAML that OpenCV can read"},
      {"{\"camera_matrix\": ", "not valid JSON"},
      {"<opencv_storage><camera_matrix>", "not XML that OpenCV can read"},
      {"", "empty"},
      {"[1, 2, 3]\n", "not calibration fields"},
      {Replace(ros, "camera_matrix:", "camera_matrx:"), "no camera_matrix"},
      {Replace(ros, k, "data: [517.3, 0, 318.6, 0, 516.5, 255.3]"), "holds 6 values"},
      {Replace(ros, "rows: 3\n  cols: 3\n  data: [517", "rows: 2\n  cols: 3\n  data: [517"),
       "camera_matrix is 2x3, not 3x3"},
      {Replace(ros, k, "data: [517.3, 0, 318.6, 0, 516.5, 255.3, 0, 0, 2]"), "[fx 0 cx; 0 fy cy"},
      {Replace(ros, k, "data: [-517.3, 0, 318.6, 0, 516.5, 255.3, 0, 0, 1]"), "focal length"},
      {Replace(ros, k, "data: [0, 0, 318.6, 0, 0, 255.3, 0, 0, 1]"), "focal length"},
      {Replace(ros, k, "data: [.inf, 0, 318.6, 0, 516.5, 255.3, 0, 0, 1]"),
       "camera_matrix.data[0] is inf, not a finite number"},
      {Replace(ros, k, "data: [517.3, 0, 718.6, 0, 516.5, 255.3, 0, 0, 1]"),
       "principal point (718.6, 255.3) lies outside the 640 x 480 image"},
      {Replace(ros, "plumb_bob", "equidistant"), "distortion_model 'equidistant' is unknown"},
      {Replace(ros, d, "data: [0.2624, .nan, -0.0054, 0.0026, 1.1633]"),
       "distortion_coefficients.data[1] is nan, not a finite number"},
      {Replace(ros, "cols: 5\n  " + d, "cols: 4\n  data: [0.2624, -0.9531, -0.0054, 0.0026]"),
       "holds 4 values, but plumb_bob has 5"},
      {Replace(ros, d, "data: [0.2624, -0.9531, -0.0054, 0.0026]"), "is 1x5 but holds 4 values"},
      {Replace(ros, d, "data: [0.2624, x, -0.0054, 0.0026, 1.1633]"),
       "data[1] is \"x\", not a number"},
      {Replace(ros, "image_height: 480\n", ""), "names image_width but not image_height"},
      {"{\"native\": {\"width\": 640, \"height\": 480, \"fx\": 500, \"cx\": 320, \"cy\": 240}}",
       "no k1"},
      {"{\"native\": {\"width\": 640, \"height\": 480, \"fx\": 500, \"cx\": 320, \"cy\": 240, "
       "\"k1\": 0, \"k2\": 0, \"distortion_model\": \"kannala-brandt\"}}",
       "native distortion model 'kannala-brandt' is not 'ha2016-d2u'"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.problem);
    const std::string message = ErrorOf(path, c.content);
    EXPECT_NE(message.find(path.string()), std::string::npos) << message;
    EXPECT_NE(message.find(c.problem), std::string::npos) << message;
  }
  const std::string size = ErrorOf(path, ros, 1280, 720);
  EXPECT_NE(size.find("640 x 480"), std::string::npos) << size;
  EXPECT_NE(size.find("1280 x 720"), std::string::npos) << size;

  EXPECT_THROW(ReadCalibrationFile(dir / "missing.yaml", 640, 480), CalibrationFileError);
  try {
    ReadCalibrationFile(dir / "missing.yaml", 640, 480);
  } catch (const CalibrationFileError& e) {
    EXPECT_NE(std::string(e.what()).find("missing.yaml: no such file"), std::string::npos);
  }
  EXPECT_THROW(ReadCalibrationFile(dir, 640, 480), CalibrationFileError);
  EXPECT_THROW(FitOpenCvCalibration(640, 480, 500, 500, 320, 240, {0.1, 0.2, 0.0}),
               CalibrationFileError);
  EXPECT_THROW(FitOpenCvCalibration(640, 480, 500, 500, 320, 240, {NAN, 0, 0, 0}),
               CalibrationFileError);
}

}  // namespace
}  // namespace dfsm
