// A small procedural body for tests and examples without
// ../shared/data: capsules on a 12-joint skeleton (hips, spine, neck, head,
// arms hanging at 45 degrees, legs), 1.8 m tall, metres, Y up, with
// skinning weights that blend each capsule into its parent bone near the
// joint. The capsules overlap and are not welded; BodySignedDistance treats
// such a body as the union of its closed pieces.
#ifndef POLYFIT_DRAPE_BODY_PROCEDURAL_BODY_H_
#define POLYFIT_DRAPE_BODY_PROCEDURAL_BODY_H_

#include "drape/body/makehuman_body.h"

namespace polyfit {

// segments: vertices around each capsule (>= 6).
SkinnedBody MakeProceduralBody(int segments = 16);

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_BODY_PROCEDURAL_BODY_H_
