#pragma once
// Garland–Heckbert plane quadrics in packed form, shared by the front end's edge collapse and the
// octree mesh's bounded edge collapse.
#include <Eigen/Core>
#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <limits>

namespace pclx {
namespace surface {
namespace detail {

/** \brief The upper triangle of the symmetric 4 × 4 matrix Σ w p pᵀ over planes p = (n, d),
  * n·x + d = 0, row by row: q0 = n0², q1 = n0 n1, q2 = n0 n2, q3 = n0 d, q4 = n1², q5 = n1 n2,
  * q6 = n1 d, q7 = n2², q8 = n2 d, q9 = d².
  */
using PlaneQuadric = Eigen::Matrix<double, 10, 1>;

/** \brief Adds w · p pᵀ for the plane n·x + d = 0. */
inline void
addPlane (PlaneQuadric& q, const Eigen::Vector3d& n, double d, double w)
{
  q[0] += w * n[0] * n[0]; q[1] += w * n[0] * n[1]; q[2] += w * n[0] * n[2]; q[3] += w * n[0] * d;
  q[4] += w * n[1] * n[1]; q[5] += w * n[1] * n[2]; q[6] += w * n[1] * d;
  q[7] += w * n[2] * n[2]; q[8] += w * n[2] * d;   q[9] += w * d * d;
}

/** \brief The weighted sum of squared distances of x to the quadric's planes. */
inline double
evaluate (const PlaneQuadric& q, const Eigen::Vector3d& x)
{
  return q[0] * x[0] * x[0] + 2 * q[1] * x[0] * x[1] + 2 * q[2] * x[0] * x[2] + q[4] * x[1] * x[1] +
         2 * q[5] * x[1] * x[2] + q[7] * x[2] * x[2] + 2 * (q[3] * x[0] + q[6] * x[1] + q[8] * x[2]) + q[9];
}

/** \brief The total weight of the planes (the trace of the 3 × 3 block, as the normals are unit). */
inline double
weightOf (const PlaneQuadric& q)
{
  return q[0] + q[4] + q[7];
}

/** \brief argmin of q by the truncated pseudo-inverse about m: directions the planes do not
  * constrain (flat or ridge-like clusters, noise) keep m's coordinate, as in dual contouring's QEF.
  * \param[in] q the quadric
  * \param[in] m the point kept in unconstrained directions
  * \param[in] keep eigenvalues at most this share of the largest are dropped
  * \return the minimiser, or m when the quadric is empty
  */
inline Eigen::Vector3d
minimise (const PlaneQuadric& q, const Eigen::Vector3d& m, double keep)
{
  Eigen::Matrix3d A;
  A << q[0], q[1], q[2], q[1], q[4], q[5], q[2], q[5], q[7];
  const Eigen::Vector3d b (-q[3], -q[6], -q[8]);
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
  es.computeDirect (A);
  const Eigen::Vector3d ev = es.eigenvalues ();
  const double emax = std::max (std::abs (ev[0]), std::max (std::abs (ev[1]), std::abs (ev[2])));
  if (!(emax > 0) || !std::isfinite (emax))
    return m;
  const Eigen::Vector3d r = b - A * m;
  Eigen::Vector3d x = m;
  for (int i = 0; i < 3; ++i)
    if (ev[i] > keep * emax)
    {
      const Eigen::Vector3d u = es.eigenvectors ().col (i);
      x += u * (u.dot (r) / ev[i]);
    }
  return x;
}

/** \brief Garland–Heckbert's boundary plane: through the boundary edge (a, b), perpendicular to
  * the triangle on it, so that a quadric holding it keeps the boundary in place.
  * \param[in] a, b the edge's ends
  * \param[in] face_normal a normal of the edge's triangle (any length)
  * \param[out] n the plane's unit normal
  * \param[out] d its offset (n·x + d = 0)
  * \return false when the edge or the triangle is degenerate (no plane)
  */
inline bool
boundaryPlane (const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& face_normal,
               Eigen::Vector3d& n, double& d)
{
  n = (b - a).cross (face_normal);
  const double len = n.norm ();
  if (!(len > 0))
    return false;
  n /= len;
  d = -n.dot (a);
  return true;
}

/** \brief Garland–Heckbert's placement for an edge collapse: the exact minimiser when the 3 × 3
  * system is well conditioned (closed-form inverse, no eigen solve: it runs for every candidate).
  * \return the minimiser, or NaN when the system is ill-conditioned (the caller falls back)
  */
inline Eigen::Vector3d
minimiseEdge (const PlaneQuadric& q)
{
  const double a = q[0], b = q[1], c = q[2], d = q[4], e = q[5], f = q[7];
  const double c00 = d * f - e * e, c01 = c * e - b * f, c02 = b * e - c * d;
  const double det = a * c00 + b * c01 + c * c02;
  const double tr = (a + d + f) / 3;
  if (!(std::abs (det) > 1e-6 * tr * tr * tr))
    return Eigen::Vector3d::Constant (std::numeric_limits<double>::quiet_NaN ());
  const double c11 = a * f - c * c, c12 = b * c - a * e, c22 = a * d - b * b;
  const Eigen::Vector3d r (-q[3], -q[6], -q[8]);
  return Eigen::Vector3d (c00 * r[0] + c01 * r[1] + c02 * r[2], c01 * r[0] + c11 * r[1] + c12 * r[2],
                          c02 * r[0] + c12 * r[1] + c22 * r[2]) / det;
}

}  // namespace detail
}  // namespace surface
}  // namespace pclx
