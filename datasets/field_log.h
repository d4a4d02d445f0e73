// A field campaign's logs as a dataset (docs/field-ingest.md): images with
// their times (a CSV, or the file names), navigation with geodetic WGS84 or
// local ENU/NED positions and Euler-angle or quaternion attitude, a clock
// offset between camera and navigation, the camera model and its mount on the
// body, and the LRF log. Everything is described by one JSON file, the field
// log description, whose paths are relative to its own folder.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "datasets/dataset.h"

namespace hdabench::datasets {

inline constexpr char kFieldLogFormatName[] = "hdabench-field-log";
inline constexpr int kFieldLogFormatVersion = 1;

// ---------------------------------------------------------------------------
// WGS84 (NIMA TR8350.2): geodetic latitude and longitude in degrees, height
// above the ellipsoid in metres; ECEF in metres.

struct Geodetic {
  double lat_deg = 0.0;
  double lon_deg = 0.0;
  double height_m = 0.0;
};

Eigen::Vector3d EcefFromGeodetic(const Geodetic& point);
// The inverse, to 1e-9 m (iterated on the latitude).
Geodetic GeodeticFromEcef(const Eigen::Vector3d& ecef_m);
// Rotation from ECEF to the east-north-up axes at a latitude and longitude.
Eigen::Matrix3d EnuFromEcef(double lat_deg, double lon_deg);
// Normal gravity of the WGS84 ellipsoid at a latitude and height (Somigliana's
// formula with the second-order free-air correction), m/s^2, along the
// ellipsoid normal: 9.7803 at the equator, 9.8322 at the poles.
double NormalGravityMps2(double lat_deg, double height_m);

// Attitude as Euler angles Z-Y-X (yaw, pitch, roll in degrees, intrinsic):
// frame_from_body = Rz(yaw) * Ry(pitch) * Rx(roll); with the NED frame and
// the FRD body, the aerospace convention.
Eigen::Matrix3d FrameFromBodyZyx(double yaw_deg, double pitch_deg, double roll_deg);
// The angles of such a rotation (pitch in [-90, 90], yaw and roll in (-180, 180]).
Eigen::Vector3d ZyxAnglesDeg(const Eigen::Matrix3d& frame_from_body);

// The camera mount from pointing angles: the optical axis leaves the body
// at `azimuth_deg` from body x (forward) toward body y (right) and
// `depression_deg` below the body x-y plane (toward body z, down); for a
// forward-looking camera (0, 0) image right is body right and image down is
// body down; `roll_deg` turns the image about the optical axis (from image x
// toward image y). "45 deg down toward the nose" is (0, 45, 0); "45 deg down
// out of the rear" (180, 45, 0); nadir with image up toward the nose
// (0, 90, 0). Returns body_from_cam.
Eigen::Matrix3d BodyFromCamPointing(double azimuth_deg, double depression_deg, double roll_deg);

// What ingest found and did: one line per fact, warning or dropped frame.
struct FieldIngestReport {
  std::vector<std::string> lines;
  int frames_found = 0;
  int frames_kept = 0;
};

// Reads the field log description at `config_path` and every file it names,
// and returns the dataset, images in memory, ready for WriteDataset. Frames
// outside the navigation or LRF span, or in a navigation gap longer than
// navigation.max_gap_s, are left out and reported. Throws InputError naming
// the file (and line, and column) of the first problems found, every
// malformed row of a table listed (at most 20); nothing is written.
Dataset IngestFieldLog(const std::string& config_path, FieldIngestReport* report);

// The opposite, for tests of ingest and for example logs: a dataset (images
// in memory) written as a field log into the new folder `dir`: log.json, the
// camera model, images/img_{time_ns}.png at image time = frame time -
// clock_offset_s, nav.csv with WGS84 positions of the local frame placed as
// east-north-up at `origin` and Z-Y-X Euler angles against each sample's own
// north-east-down axes, lrf.csv, the mount as a matrix, gravity as the
// dataset's. Truth is not written. Throws InputError when `dir` exists and is
// not empty or a file cannot be written, and when the dataset's LRF beam is
// not the same in every sample.
void WriteFieldLog(const Dataset& dataset, const std::string& dir, const Geodetic& origin, double clock_offset_s);

}  // namespace hdabench::datasets
