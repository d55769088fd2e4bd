#include "estimator/optics/radiance.h"

#include <cmath>

namespace weavefit {

const char* ProfileModelName(ProfileModel model) {
  switch (model) {
    case ProfileModel::kSmooth:
      return "SMOOTH";
    case ProfileModel::kSinusoid:
      return "SINUSOID";
    case ProfileModel::kSawtooth:
      return "SAWTOOTH";
  }
  return "UNKNOWN";
}

double PeakSpacingRad(double max_slope) { return 2.0 * std::atan(max_slope); }

double SinusoidMaxSlope(double amplitude_mm, double wavelength_mm) {
  return 2.0 * M_PI * amplitude_mm / wavelength_mm;
}

double SawtoothMaxSlope(double amplitude_mm, double wavelength_mm) {
  return 4.0 * amplitude_mm / wavelength_mm;
}

}  // namespace weavefit
