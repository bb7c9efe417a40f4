#pragma once
// A bound on the distances of a moving point to a set of planes, kept without the planes: the
// edge collapse's cheap test before it reads a cluster's planes.
#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <limits>

namespace pclx {
namespace surface {
namespace detail {

/** \brief Bounds the distances of a point to a set of planes n·x + d = 0 (unit normals) without
  * reading them: an axis a, a spread s ≥ |n − a| over their normals, and a reach r ≥ the largest
  * distance of the point the summary was made at. At that point moved by Δ, by the triangle
  * inequality, every plane satisfies |n·x + d| ≤ r + |a·Δ| + s |Δ|.
  */
struct PlaneSetBound
{
  Eigen::Vector3f axis = Eigen::Vector3f::Zero ();  ///< the normals' normalised mean (any unit vector is valid)
  float spread = 0.f;                               ///< at least |n − axis| over the normals
  float reach = 0.f;                                ///< at least the largest distance at the summary's point

  /** \brief The summary of planes [first, last) seen from p (all zero for no planes).
    * \param[in] first, last the planes (unit normal, offset)
    * \param[in] p the point the reach is measured at
    * \return the summary */
  static PlaneSetBound
  of (const Eigen::Vector4f* first, const Eigen::Vector4f* last, const Eigen::Vector3f& p)
  {
    PlaneSetBound b;
    if (first == last)
      return b;
    Eigen::Vector3f sum = Eigen::Vector3f::Zero ();
    for (const Eigen::Vector4f* k = first; k != last; ++k)
      sum += k->head<3> ();
    const float len = sum.norm ();
    b.axis = len > 0.5f ? Eigen::Vector3f (sum / len) : Eigen::Vector3f (first->head<3> ());
    for (const Eigen::Vector4f* k = first; k != last; ++k)
    {
      b.spread = std::max (b.spread, (k->head<3> () - b.axis).norm ());
      b.reach = std::max (b.reach, std::abs (k->head<3> ().dot (p) + (*k)[3]));
    }
    return b;
  }

  /** \brief The summary of two sets together, at a point within \a reach of all their planes.
    * \param[in] a, b the two summaries
    * \param[in] wa, wb their weights in the merged axis (e.g. their plane counts)
    * \param[in] reach a bound on the distance of the new point to the planes of both
    * \return the merged summary */
  static PlaneSetBound
  merge (const PlaneSetBound& a, float wa, const PlaneSetBound& b, float wb, float reach)
  {
    PlaneSetBound m;
    const Eigen::Vector3f sum = wa * a.axis + wb * b.axis;
    const float len = sum.norm ();
    m.axis = len > 0 ? Eigen::Vector3f (sum / len) : a.axis;
    m.spread = std::max (a.spread + (a.axis - m.axis).norm (), b.spread + (b.axis - m.axis).norm ());
    m.reach = reach;
    return m;
  }

  /** \brief A bound on the distance to every plane of the point moved by \a delta.
    * \param[in] delta the move from the summary's point
    * \param[in] slack added for rounding (see slackAt ())
    * \return the bound */
  float
  at (const Eigen::Vector3f& delta, float slack) const
  {
    return reach + std::abs (axis.dot (delta)) + spread * delta.norm () + slack;
  }

  /** \brief A slack that keeps at () above distances computed in float at x (16 ulps of |x|₁).
    * \param[in] x the point
    * \return the slack */
  static float
  slackAt (const Eigen::Vector3f& x)
  {
    return 16 * std::numeric_limits<float>::epsilon () * (1 + x.cwiseAbs ().sum ());
  }
};

}  // namespace detail
}  // namespace surface
}  // namespace pclx
