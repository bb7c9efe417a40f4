#pragma once
// bench_normals --wide / --speed / --quick: the wide normals protocol (shapes we
// never tuned to, PCPNet noise levels, PCA k sweep with an oracle row, CGAL jet and VCM,
// Open3D), a speed sweep against PCL at 100k-1M points, and MST orientation on closed shapes.
#include "bench_csv.h"

#include <string>
#include <vector>

namespace pclx {
namespace bench {

struct WideOptions
{
  bool wide = false;   // the shape × noise table
  bool speed = false;  // the speed sweep (100k, 300k, 1M; noisy 100k against the oracle k)
  bool quick = false;  // generated shapes only, a few thousand points (CTest smoke)
  bool orient = false; // orientation only: MST on our / PCA k = 18 / exact normals, and Open3D's
  int threads = 2;
  std::string data;                 // shared data folder; empty: generated shapes only
  std::vector<std::string> shapes;  // only these shapes (empty: all)
  std::string peers = "all";        // all | pca (ours + the PCA sweep only: quick checks of the class)
  bool cgal = true, open3d = true;
  std::size_t points = 100000;
  int speed_repeats = 2;                  // speed sweep: best of this many calls (wall and CPU)
  std::vector<std::size_t> speed_sizes;   // speed sweep's clean sizes (empty: 100k, 300k, 1M)
  bool speed_noisy = true;                // speed sweep: also the noisy rows against oracle-k PCA
  std::string dump;  // write each shape's clean sample (positions + truth normals) as <dump>/<shape>.ply
};

// Prints rows (module normals, params sweep=wide|speed|orient;noise=σ/diag) and progress on
// stderr. Returns the process exit code.
int runWide (const WideOptions& opt, CsvWriter& out);

}  // namespace bench
}  // namespace pclx
