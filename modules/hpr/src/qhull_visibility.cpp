#include <pclx/hpr/detail/qhull_visibility.h>

extern "C" {
#include <libqhull_r/qhull_ra.h>
}

#include <cstdio>
#include <cstdlib>

namespace pclx {
namespace hpr {
namespace detail {

HullResult
flippedHull (const std::vector<Eigen::Vector3d>& points, bool triangulate, bool joggle)
{
  HullResult result;
  const int n = static_cast<int> (points.size ());
  std::vector<coordT> coords (3 * (points.size () + 1));
  for (int i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k)
      coords[3 * i + k] = points[i][k];
  coords[3 * n] = coords[3 * n + 1] = coords[3 * n + 2] = 0.0;  // the viewpoint C

  // Qhull reports problems on a FILE*: keep them in memory for the caller's message.
  char* err_buf = nullptr;
  std::size_t err_len = 0;
  FILE* err = open_memstream (&err_buf, &err_len);

  qhT qh_qh;
  qhT* qh = &qh_qh;
  qh_zero (qh, err);
  // Qt only when facets are wanted: triangulating costs time and changes no vertex.
  // Q5 (no final outer-plane check) and Q8 (no near-inside point bookkeeping) only concern
  // facet planes and coplanar points, not which points are vertices, and save time.
  std::string flags = "qhull Q5 Q8";
  if (triangulate)
    flags += " Qt";
  if (joggle)
    flags += " QJ";
  const int code = qh_new_qhull (qh, 3, n + 1, coords.data (), False, const_cast<char*> (flags.c_str ()),
                                 nullptr, err);
  if (code == 0)
  {
    result.ok = true;
    vertexT* vertex;
    FORALLvertices
    {
      const int id = qh_pointid (qh, vertex->point);
      if (id >= 0 && id < n)
        result.vertices.push_back (id);
    }
    if (triangulate)
    {
      facetT* facet;
      FORALLfacets
      {
        int ids[3], m = 0;
        bool touches_viewpoint = false;
        vertexT** vertexp;
        FOREACHvertex_ (facet->vertices)
        {
          const int id = qh_pointid (qh, vertex->point);
          touches_viewpoint |= (id == n);
          if (m < 3)
            ids[m] = id;
          ++m;
        }
        if (m != 3 || touches_viewpoint)
          continue;
        // Orient each triangle to face the viewpoint (the origin).
        const Eigen::Vector3d a = points[ids[0]], b = points[ids[1]], c = points[ids[2]];
        if ((b - a).cross (c - a).dot (-a) < 0)
          std::swap (ids[1], ids[2]);
        result.triangles.emplace_back (ids[0], ids[1], ids[2]);
      }
    }
  }
  int curlong = 0, totlong = 0;
  qh_freeqhull (qh, !qh_ALL);
  qh_memfreeshort (qh, &curlong, &totlong);
  std::fclose (err);
  if (!result.ok)
    result.error = err_buf ? std::string (err_buf, err_len) : "qhull failed";
  std::free (err_buf);
  return result;
}

}  // namespace detail
}  // namespace hpr
}  // namespace pclx
