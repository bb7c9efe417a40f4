#pragma once
// Open3D peer, isolated in its own translation unit (Open3D headers are heavy and
// bring their own Eigen settings).
#include <Eigen/Core>
#include <vector>

namespace open3d_peer {

// EstimateNormals with a kNN(k) search; returns seconds.
double estimateNormals (const std::vector<Eigen::Vector3d>& points, int k, std::vector<Eigen::Vector3d>& normals);
// EstimateNormals with Open3D's hybrid search (at most max_nn neighbours within radius); seconds.
double estimateNormalsHybrid (const std::vector<Eigen::Vector3d>& points, double radius, int max_nn,
                              std::vector<Eigen::Vector3d>& normals);
// OrientNormalsConsistentTangentPlane(k) on given normals (in place); returns seconds.
double orientConsistent (const std::vector<Eigen::Vector3d>& points, std::vector<Eigen::Vector3d>& normals, int k);

}  // namespace open3d_peer
