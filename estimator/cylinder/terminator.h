// Inferring a limb lost in darkness from the lit limb and the terminator.
#ifndef WEAVEFIT_ESTIMATOR_CYLINDER_TERMINATOR_H_
#define WEAVEFIT_ESTIMATOR_CYLINDER_TERMINATOR_H_

#include "absl/status/statusor.h"
#include "estimator/cylinder/azimuth_mapping.h"
#include "estimator/cylinder/cylinder_detection.h"
#include "estimator/io/image.h"

namespace weavefit {

// What the image outside the cylinder looks like.
struct BackgroundLevel {
  double level = 0.0;
  double noise = 0.0;  // per pixel
};

// At a large phase angle α the limb away from the light can be as dark as
// the background, and the edge found on that side is then the terminator,
// where the surface stops being lit: azimuth φ_T = α − sign(α)·90°
// (DESIGN.md §2 signs). Given `edges`, a geometry whose lit-side limb is real
// and whose other "limb" is that terminator, this returns the cylinder with
// the lit limb kept, the radius fixed by where the terminator sits between
// the two, and the dark limb flagged as not observed.
//
// The terminator is located to a fraction of a pixel by fitting the surface
// radiance there, across the rows between edges.top_row and bottom_row, up
// to where the glints begin, as background + D·max(0, cos(φ − α)) (the
// Lambertian term of DESIGN.md §3) and/or S·[cos(φ − α) > 0]·cos(α/2)/cos φ
// (the grazing scatter), the second term only when it pays for itself (BIC,
// and at least a 3-sigma gain), each pixel integrated over its width, for
// radii around the first guess. The same two terms are fitted, with an
// offset of their own, to a window by the lit limb between it and the
// lobe's glints, where 1/cos φ rises steeply: that pins S, which at the
// terminator alone trades off against the radius.
// Fails with INVALID_ARGUMENT when no such terminator explains the edge: no
// lit term, glints right at the edge, or a residual far above the noise.
absl::StatusOr<CylinderGeometry> InferDarkLimb(const Image& luminance,
                                               const CylinderGeometry& edges,
                                               double phase_angle_rad,
                                               const Projection& projection,
                                               const BackgroundLevel& background);

}  // namespace weavefit

#endif  // WEAVEFIT_ESTIMATOR_CYLINDER_TERMINATOR_H_
