// Sensor faults applied to a dataset in memory: the LRF, the navigation, the
// clock between camera and navigation, and the images, each with one
// magnitude in stated units (docs/faults.md). What a fault changes is the
// measured data the flight method reads (frames, navigation, LRF); the truth
// is never touched, so a run on the faulted dataset is judged against the
// same truth as the clean one. Works on any dataset: synthetic, ingested
// field logs, StereoLunar.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "datasets/dataset.h"

namespace hdabench::datasets {

enum class FaultKind {
  kLrfAbsent,        // no LRF sample at all (magnitude unused)
  kLrfStuck,         // the LRF repeats the range it measured MAGNITUDE s before image 1
  kLrfScale,         // range * (1 + MAGNITUDE): a scale error, fraction (0.05 = +5 %)
  kLrfOffset,        // range + MAGNITUDE metres
  kLrfNoise,         // range + Gaussian noise of MAGNITUDE metres (sigma), per sample
  kLrfRock,          // the beam hits a rock MAGNITUDE metres tall: the range it measures is short
                     // by that height along the beam
  kNavPositionBias,  // every navigation position moved by MAGNITUDE metres along the pair's motion
  kNavDrift,         // position error growing at MAGNITUDE m/s along the pair's motion from image 1
  kAttitudeBias,     // every navigation attitude turned by MAGNITUDE degrees about the horizontal
                     // axis across the pair's motion
  kAttitudeJump,     // the same turn from halfway between the two images on (degrees)
  kClockOffset,      // the camera's time stamps late on the navigation's by MAGNITUDE seconds
  kImageBlur,        // both images blurred, Gaussian of MAGNITUDE pixels (sigma)
  kImageSaturated,   // both images' signal times MAGNITUDE (> 1), clipped at full scale
  kImageDark,        // both images' signal divided by MAGNITUDE (> 1), requantized
  kFrameRepeated,    // image 2 is image 1 again: the camera delivered one frame twice
                     // (magnitude unused)
  kFrameDropped,     // image 2 never arrived: the next frame the camera delivered takes its
                     // place, with its own time and truth (magnitude unused)
};

struct Fault {
  FaultKind kind = FaultKind::kLrfScale;
  double magnitude = 0.0;
};

// What the catalogue says of one kind of fault.
struct FaultInfo {
  FaultKind kind;
  const char* name;         // command-line name: "lrf-scale"
  const char* unit;         // "fraction", "m", "s", "deg", "px", "x", "" (no magnitude)
  const char* description;  // one line
  // The magnitudes `hdabench faults` sweeps by default: from what a healthy
  // sensor shows to a gross failure, in `unit`. One value (1) for the faults
  // without a magnitude.
  std::vector<double> sweep;
};

// Every kind of fault, in FaultKind order.
const std::vector<FaultInfo>& FaultCatalogue();

// The catalogue entry of a kind.
const FaultInfo& InfoOf(FaultKind kind);

// The kind of a command-line name; throws InputError listing the names when
// it is none of them.
FaultKind ParseFaultKind(const std::string& name);

// "lrf-scale=0.05" style label of a fault ("lrf-absent" without a magnitude).
std::string FaultLabel(const Fault& fault);

// "NAME" or "NAME=M1,M2,...": the fault at each magnitude given, or at its
// default sweep when none is given (one case for a fault without a
// magnitude). Throws InputError naming the text: an unknown name, a
// magnitude that is not a finite number, or one given to a fault that takes
// none.
std::vector<Fault> ParseFaults(const std::string& text);

// One fault, "NAME=M" (or "NAME" for a fault without a magnitude), as
// ParseFaults reads it; a sweep is an InputError too ("'lrf-scale' is a
// sweep of 8 magnitudes: give one, NAME=M").
Fault ParseOneFault(const std::string& text);

// Throws InputError ("fault image-blur=-1: expected a sigma > 0 pixels")
// when the fault's magnitude is outside what the fault takes, whatever the
// dataset: a check before the work (ApplyFault makes it too).
void CheckFaultMagnitude(const Fault& fault);

// Applies `fault` to `dataset` for the pair (frame1, frame2): its LRF,
// navigation, frame times or the pair's images (which must be loaded for the
// image faults). `seed` draws the noise of kLrfNoise (the same seed, the same
// bytes). Throws InputError for a magnitude outside the fault's domain (not
// finite, a scale that makes ranges non-positive, a gain <= 1, ...), a frame
// outside the dataset, images not loaded for an image fault, a clock
// offset that puts a frame outside the navigation, or a dropped image 2 with
// no frame after it (or not after image 1); the dataset is then left as it
// was. A dropped frame removes frame2 from the frames and the truth and
// numbers the later frames one lower, so that frame2 names the next frame.
void ApplyFault(const Fault& fault, int frame1, int frame2, std::uint64_t seed, Dataset* dataset);

}  // namespace hdabench::datasets
