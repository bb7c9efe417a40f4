#pragma once
// Point splats with VTK: every point an opaque, depth-tested disc of its own radius
// (vtkPointGaussianMapper with a disc shader), coloured by the cloud's rgb, by a level palette
// or by height. SplatRenderer draws a changing list of point batches, e.g. the front of a
// level-of-detail hierarchy (pcl::ObliqueCutOctree::evaluate) while the hierarchy grows.
#include <pcl/point_types.h>

#include <vtkActor.h>
#include <vtkPolyData.h>
#include <vtkRenderer.h>
#include <vtkSmartPointer.h>

#include <Eigen/Core>

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <unordered_map>
#include <vector>

namespace pclx {
namespace apps {

/** \brief The colour of a splat: the point's rgb, a palette entry per hierarchy level, or the
  * point's height along an up direction over a bounding box (a blue, teal, sand, white ramp
  * that reads well on a dark background).
  */
class SplatColouring
{
public:
  /** \brief What the colour shows. */
  enum class Mode
  {
    RGB,    ///< the point's own rgb (height for point types without colour)
    LEVEL,  ///< one palette colour per hierarchy level (0..21)
    HEIGHT  ///< the height ramp between the box's lowest and highest corner
  };

  /** \brief Colours for a box and an up direction.
    * \param[in] mode what the colour shows
    * \param[in] up the up direction of the height ramp (need not be unit length)
    * \param[in] lo the box's minimum corner
    * \param[in] hi the box's maximum corner
    */
  SplatColouring (Mode mode, const Eigen::Vector3f& up, const Eigen::Vector3f& lo, const Eigen::Vector3f& hi);

  /** \brief Writes the colour of one point.
    * \param[in] p the point
    * \param[in] level the hierarchy level of the point's batch (used by Mode::LEVEL)
    * \param[out] out three bytes: r, g, b
    */
  template <typename PointT>
  void
  operator() (const PointT& p, int level, std::uint8_t* out) const
  {
    if constexpr (pcl::traits::has_color_v<PointT>)
      if (mode_ == Mode::RGB)
      {
        out[0] = p.r;
        out[1] = p.g;
        out[2] = p.b;
        return;
      }
    const std::uint8_t* c =
        mode_ == Mode::LEVEL ? level_[level].data () : ramp_[rampIndex (p.getVector3fMap ())].data ();
    out[0] = c[0];
    out[1] = c[1];
    out[2] = c[2];
  }

private:
  template <typename Derived>
  int
  rampIndex (const Eigen::MatrixBase<Derived>& p) const
  {
    return static_cast<int> (std::clamp ((up_.dot (p) - z0_) * inv_dz_, 0.f, 255.f));
  }

  Mode mode_;
  Eigen::Vector3f up_;
  float z0_ = 0, inv_dz_ = 1;
  std::array<std::array<std::uint8_t, 3>, 256> ramp_{};
  std::array<std::array<std::uint8_t, 3>, 22> level_{};
};

/** \brief Raw views of a splat poly data's three arrays, sized by resizeSplatData (). */
struct SplatArrays
{
  float* xyz = nullptr;           ///< 3 floats per point: the position
  std::uint8_t* rgb = nullptr;    ///< 3 bytes per point: the colour
  float* scale = nullptr;         ///< 1 float per point: the disc radius in world units
};

/** \brief A poly data with empty float points, an "rgb" scalar array and a "scale" array.
  * \return the new poly data
  */
vtkSmartPointer<vtkPolyData>
makeSplatData ();

/** \brief Resizes the three arrays of a poly data from makeSplatData () to n points.
  * \param[in,out] data the poly data
  * \param[in] n the number of points
  * \return pointers to the arrays' first elements
  */
SplatArrays
resizeSplatData (vtkPolyData& data, std::size_t n);

/** \brief Marks the arrays and the poly data modified, after they were written through
  * SplatArrays, so that VTK uploads them again.
  * \param[in,out] data the poly data
  */
void
markSplatDataModified (vtkPolyData& data);

/** \brief An actor drawing a poly data from makeSplatData () as opaque, depth-tested discs
  * of radius "scale", slightly darker at the rim. (vtkPointGaussianMapper's default is an
  * additive Gaussian, which sums overlapping splats to white.)
  * \param[in] data the poly data
  * \return the actor
  */
vtkSmartPointer<vtkActor>
makeSplatActor (vtkPolyData* data);

/** \brief Fills a poly data from makeSplatData () with the points of `count` batches.
  *
  * A batch (Item) has the fields of pcl::ObliqueCutOctree<PointT>::Item: `points` (indexable
  * points), `num_points`, `splat_radius`, and `node` (a pointer, may be null, whose `level`
  * is the batch's level).
  * \param[in] items the first batch
  * \param[in] count the number of batches
  * \param[in] colour the colouring
  * \param[in,out] data the poly data
  */
template <typename Item>
void
fillSplatData (const Item* items, std::size_t count, const SplatColouring& colour, vtkPolyData& data)
{
  std::size_t n = 0;
  for (std::size_t k = 0; k < count; ++k)
    n += items[k].num_points;
  SplatArrays a = resizeSplatData (data, n);
  for (std::size_t k = 0; k < count; ++k)
  {
    const Item& it = items[k];
    const int level = it.node ? it.node->level : 0;
    for (std::uint32_t i = 0; i < it.num_points; ++i, a.xyz += 3, a.rgb += 3, ++a.scale)
    {
      const auto& q = it.points[i];
      a.xyz[0] = q.x;
      a.xyz[1] = q.y;
      a.xyz[2] = q.z;
      colour (q, level, a.rgb);
      *a.scale = it.splat_radius;
    }
  }
  markSplatDataModified (data);
}

/** \brief Draws a list of point batches (see fillSplatData () for a batch's fields) as
  * splats, redrawing only when the list changed.
  *
  * Two ways to draw: one poly data refilled whenever the list changes, or one actor per batch
  * (cached by the batch's node pointer) whose visibility is switched, actors unused for a
  * while being dropped.
  */
class SplatRenderer
{
public:
  /** \brief A renderer drawing into `renderer`.
    * \param[in] renderer where the actors go (null: nothing is shown, the arrays are still
    * filled, e.g. to measure that work without a window)
    * \param[in] per_node true: one actor per batch; false: one poly data for all
    */
  SplatRenderer (vtkRenderer* renderer, bool per_node);

  /** \brief Shows `items` when they differ from the batches shown.
    * \param[in] items the batches to show
    * \param[in] colour the colouring of new arrays
    * \return true when the shown set changed
    */
  template <typename Item>
  bool
  update (const std::vector<Item>& items, const SplatColouring& colour)
  {
    if (!changed (items))
      return false;
    shown_.clear ();
    for (const auto& it : items)
      shown_.push_back (it.node);
    ++generation_;
    if (!per_node_)
    {
      fillSplatData (items.data (), items.size (), colour, *data_);
      return true;
    }
    for (const auto& it : items)
    {
      Cached& e = cache_[it.node];
      if (!e.actor)
      {
        e.data = makeSplatData ();
        fillSplatData (&it, 1, colour, *e.data);
        addActor (e);
      }
      e.actor->SetVisibility (true);
      e.generation = generation_;
    }
    hideAndDropUnused ();
    return true;
  }

private:
  /** \brief An actor of one batch and the generation that last showed it. */
  struct Cached
  {
    vtkSmartPointer<vtkPolyData> data;
    vtkSmartPointer<vtkActor> actor;
    std::size_t generation = 0;
  };

  template <typename Item>
  bool
  changed (const std::vector<Item>& items) const
  {
    bool same = items.size () == shown_.size ();
    for (std::size_t i = 0; same && i < items.size (); ++i)
      same = items[i].node == shown_[i] && (items[i].node || items[i].num_points == 0);
    return !same;
  }

  void
  addActor (Cached& e);

  void
  hideAndDropUnused ();

  vtkRenderer* renderer_;
  bool per_node_;
  vtkSmartPointer<vtkPolyData> data_;
  vtkSmartPointer<vtkActor> actor_;
  std::vector<const void*> shown_;
  std::unordered_map<const void*, Cached> cache_;
  std::size_t generation_ = 0;
};

}  // namespace apps
}  // namespace pclx
