// profile_omicron: stage breakdown of one in-memory ObliqueCutOctree build.
//   profile_omicron FILE.pcd [--file] [--threads 2] [--repeat 3] [--potree DIR] [--no-front]
// Loads FILE with pcl::io::loadPCDFile (or, with --file, builds from the file path) and prints
// the build's stage times (Statistics) and the minor page faults of the build (getrusage).
// --no-front builds without the front (setFrontDuringBuild (false)).
// With --potree, each build is also written to DIR as Potree 2.0 (PotreeWriter::write); the
// last line is the process's VmHWM (the whole process: run it with --repeat 1 for one build).
#include <pclx/omicron/oblique_cut_octree.h>
#include <pclx/omicron/potree_writer.h>
#include <pclx/testing/run_stats.h>

#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>

#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <string>

static long minflt ()
{
  rusage u{};
  getrusage (RUSAGE_SELF, &u);
  return u.ru_minflt;
}

// user + system CPU seconds of the process (less noisy than wall time on the shared VM).
static double cpu ()
{
  rusage u{};
  getrusage (RUSAGE_SELF, &u);
  return u.ru_utime.tv_sec + u.ru_stime.tv_sec + 1e-6 * (u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

int main (int argc, char** argv)
{
  if (argc < 2)
  {
    std::fprintf (stderr, "usage: profile_omicron FILE.pcd [--file] [--threads N] [--repeat N] [--potree DIR] [--no-front]\n");
    return 2;
  }
  const std::string path = argv[1];
  std::string potree_dir;
  bool from_file = false, front = true;
  int threads = 2, repeat = 3;
  for (int i = 2; i < argc; ++i)
  {
    if (!std::strcmp (argv[i], "--file"))
      from_file = true;
    else if (!std::strcmp (argv[i], "--threads") && i + 1 < argc)
      threads = std::atoi (argv[++i]);
    else if (!std::strcmp (argv[i], "--repeat") && i + 1 < argc)
      repeat = std::atoi (argv[++i]);
    else if (!std::strcmp (argv[i], "--potree") && i + 1 < argc)
      potree_dir = argv[++i];
    else if (!std::strcmp (argv[i], "--no-front"))
      front = false;
  }
  std::printf ("VmRSS at start %.1f MB\n", pclx::testing::procStatusKb ("VmRSS") / 1024.0);
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud (new pcl::PointCloud<pcl::PointXYZ>);
  if (!from_file)
  {
    const auto t = std::chrono::steady_clock::now ();
    if (pcl::io::loadPCDFile (path, *cloud) < 0)
      return 1;
    std::printf ("load %.3f s (%zu points)\n",
                 std::chrono::duration<double> (std::chrono::steady_clock::now () - t).count (), cloud->size ());
  }
  for (int r = 0; r < repeat; ++r)
  {
    pcl::ObliqueCutOctree<pcl::PointXYZ> octree;
    if (from_file)
      octree.setInputFile (path);
    else
      octree.setInputCloud (cloud);
    octree.setThreads (threads);
    octree.setFrontDuringBuild (front);
    const long f0 = minflt ();
    const double c0 = cpu ();
    if (!octree.build ())
      return 1;
    const long f1 = minflt ();
    const double c1 = cpu ();
    const auto s = octree.getStatistics ();
    std::printf ("%s read %.3f  first_chunk %.3f  first_front %.3f  total %.3f s  faults %ld (%.0f MB at 4 KiB)  "
                 "cpu %.2f s  sorted %.0f MB hierarchy %.0f MB\n",
                 from_file ? "file " : "cloud", s.seconds_read, s.seconds_to_first_chunk, s.seconds_to_first_front,
                 s.seconds_total, f1 - f0, (f1 - f0) * 4096.0 / 1e6, c1 - c0, s.sorted_bytes / 1e6, s.hierarchy_bytes / 1e6);
    if (!potree_dir.empty ())
    {
      std::printf ("VmHWM after the build %.1f MB\n", pclx::testing::procStatusKb ("VmHWM") / 1024.0);
      const auto t = std::chrono::steady_clock::now ();
      const double write_cpu = cpu ();
      pcl::PotreeWriter<pcl::PointXYZ> writer;
      if (!writer.write (octree, potree_dir))
        return 1;
      std::printf ("potree write %.3f s  cpu %.2f s\n",
                   std::chrono::duration<double> (std::chrono::steady_clock::now () - t).count (), cpu () - write_cpu);
    }
    std::fflush (stdout);
  }
  std::printf ("VmHWM %.1f MB\n", pclx::testing::procStatusKb ("VmHWM") / 1024.0);
  return 0;
}
