// The focal length a camera writes into its JPEGs (EXIF), as a prior for the
// self-calibration of an uploaded burst.
#pragma once

#include <optional>
#include <string>

namespace dfsm {

// EXIF FocalLengthIn35mmFilm (tag 0xA405) of a JPEG file's bytes, in mm; empty
// for anything else (PNG, no EXIF, no such tag, 0 = unknown). Never throws.
std::optional<double> ReadExifFocalLength35mm(const std::string& file_bytes);

// The 35 mm equivalent focal length in pixels of a width x height image: the
// equivalence is by the diagonal (43.27 mm on 35 mm film), as CIPA DC-008
// defines it. Digital zoom or a cropped video mode make it wrong, which is
// why it only ever enters as a prior.
double FocalPixelsFrom35mm(double focal_35mm, int width, int height);
// Its inverse: what a camera of focal length `f_px` writes, unrounded.
double Focal35mmFromPixels(double f_px, int width, int height);

}  // namespace dfsm
