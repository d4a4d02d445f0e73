// What the methods of methods/ share: timing, an ROI's points and fit, the
// pair's matches pooled, the navigation's up and level ground, and a
// whole-pair reconstruction's ROIs. Internal to reference_compare.
#pragma once

#include <chrono>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core/types.hpp>

#include "reference/compare/method.h"

namespace hdabench::reference::methods {

double SecondsSince(std::chrono::steady_clock::time_point start);

// Whether an image-1 observation lies in an ROI's image-1 box: its nearest
// pixel centre does.
bool InBox(const Eigen::Vector2d& pixel, const cv::Rect& box);

// Fills a method's ROI from its points in the ROI (FitRoiPoints with the two
// camera centres), its point accuracy against the truth DEM where there is one,
// and its support: the points' image-1 pixels (pixels1, parallel), alike.
void FillFromPoints(const std::vector<Eigen::Vector3d>& points, const std::vector<Eigen::Vector2d>& pixels1,
                    const Eigen::Vector3d& centre1,
                    const Eigen::Vector3d& centre2, const datasets::Dataset& dataset,
                    int min_points, MethodRoi* roi);

// Bearings of pixels through the camera model; valid[i] == 0 where not.
std::vector<Eigen::Vector3d> Bearings(const calib::CameraModel& camera,
                                      const std::vector<cv::Point2d>& pixels,
                                      std::vector<unsigned char>* valid);

// Every match of the pair, ROIs first (in ROI order), then the tiles';
// *first, when given, gets ROI i's range [first[i], first[i + 1]).
void PoolPairMatches(const PairMatches& matches, std::vector<Eigen::Vector3d>* b1,
                     std::vector<Eigen::Vector3d>* b2, std::vector<size_t>* first = nullptr);

// The unit vector against gravity, in camera 1 (navigation).
Eigen::Vector3d UpInCam1(const PairContext& ctx);

// Level ground through the laser range finder's point: p . X = 1 in camera 1.
Eigen::Vector3d LevelGroundInCam1(const PairContext& ctx);

// Appends to a method's note how many ROIs it left unfitted for low
// parallax, and why (nothing when none).
void NoteLowParallax(const std::vector<MethodRoi>& rois, const std::string& why, MethodSummary* summary);

// A whole-pair reconstruction's ROIs (RoisOfReconstruction) and summary: ok
// or its failure, its time, and where its logs are.
void FillFromReconstruction(const PairReconstruction& recon, const PairContext& ctx,
                            std::vector<MethodRoi>* rois, MethodSummary* summary);

// The reconstruction's relative pose against the true one, where both exist.
void PoseErrorAgainstTruth(const PairReconstruction& recon, const PairContext& ctx, MethodSummary* summary);

}  // namespace hdabench::reference::methods
