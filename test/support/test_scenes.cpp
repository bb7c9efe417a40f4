// Tests of the synthetic scene generators: shapes, sampling, degradations.
#include <pclx/testing/degradation.h>
#include <pclx/testing/set_scores.h>
#include <pclx/testing/shapes.h>

#include <gtest/gtest.h>

#include <cmath>

using namespace pclx::testing;

namespace {
double
angleDeg (const Eigen::Vector3f& a, const Eigen::Vector3f& b)
{
  return std::acos (std::clamp<double> (a.normalized ().dot (b.normalized ()), -1.0, 1.0)) * 180.0 / M_PI;
}
}  // namespace

TEST (Shapes, SphereVerticesOnSphereAndFacesOutward)
{
  const Eigen::Vector3f c (1, 2, 3);
  const TriangleMesh m = makeSphere (2.f, 3, c);
  EXPECT_EQ (m.faces.size (), 20u * 64u);
  for (const auto& v : m.vertices)
    EXPECT_NEAR ((v - c).norm (), 2.f, 1e-5f);
  for (std::size_t f = 0; f < m.faces.size (); ++f)
  {
    const Eigen::Vector3f centroid =
        (m.vertices[m.faces[f][0]] + m.vertices[m.faces[f][1]] + m.vertices[m.faces[f][2]]) / 3.f;
    EXPECT_GT (m.faceNormal (f).dot (centroid - c), 0.f) << "face " << f;
  }
  // Area converges to 4πr² from below.
  EXPECT_NEAR (m.totalArea (), 4 * M_PI * 4, 0.02 * 4 * M_PI * 4);
}

TEST (Shapes, BoxTorusPlateAreasAndOrientation)
{
  const TriangleMesh box = makeBox (Eigen::Vector3f (1, 2, 3), 4);
  EXPECT_NEAR (box.totalArea (), 2 * (1 * 2 + 2 * 3 + 1 * 3), 1e-4);
  for (std::size_t f = 0; f < box.faces.size (); ++f)
  {
    const Eigen::Vector3f centroid = (box.vertices[box.faces[f][0]] + box.vertices[box.faces[f][1]] +
                                      box.vertices[box.faces[f][2]]) / 3.f;
    EXPECT_GT (box.faceNormal (f).dot (centroid), 0.f);  // outward from the centre
  }
  const float R = 1.f, r = 0.25f;
  const TriangleMesh torus = makeTorus (R, r, 256, 64);
  EXPECT_NEAR (torus.totalArea (), 4 * M_PI * M_PI * R * r, 0.01 * 4 * M_PI * M_PI * R * r);
  for (std::size_t f = 0; f < torus.faces.size (); f += 97)
  {
    const Eigen::Vector3f p = torus.vertices[torus.faces[f][0]];
    const Eigen::Vector3f ring = Eigen::Vector3f (p.x (), p.y (), 0).normalized () * R;
    EXPECT_GT (torus.faceNormal (f).dot (p - ring), 0.f) << "torus normals point out of the tube";
  }
  const TriangleMesh plate = makeThinPlate (1.f, 0.01f, 4);
  EXPECT_NEAR (plate.totalArea (), 2 * 1 + 4 * 0.01, 1e-4);
  const TriangleMesh sheets = makeParallelSheets (1.f, 0.02f, 4);
  EXPECT_NEAR (sheets.totalArea (), 2.f, 1e-4);
}

TEST (Sampling, EverySampleOfASphereLiesOnItWithAnalyticNormal)
{
  const TriangleMesh m = makeSphere (1.f, 5);
  const SampledCloud s = sampleUniform (m, 20000, 7);
  ASSERT_EQ (s.cloud.size (), 20000u);
  ASSERT_EQ (s.face.size (), 20000u);
  double worst_angle = 0;
  for (const auto& p : s.cloud)
  {
    // Flat facets of a 5-level icosphere sag at most 1 − cos(edge/2) ≈ 0.0006 below the sphere.
    EXPECT_LE (p.getVector3fMap ().norm (), 1.f + 1e-5f);
    EXPECT_GE (p.getVector3fMap ().norm (), 0.999f);
    worst_angle = std::max (worst_angle, angleDeg (p.getNormalVector3fMap (), p.getVector3fMap ()));
  }
  // Mesh (face) normals match the analytic normal p/|p| to within the facet size.
  EXPECT_LT (worst_angle, 3.0);
}

TEST (Sampling, UniformIsAreaProportionalAndGradientFallsOff)
{
  const TriangleMesh box = makeBox (Eigen::Vector3f (2, 1, 1), 2);
  const SampledCloud s = sampleUniform (box, 40000, 3);
  int top = 0, side_x = 0;
  for (const auto& p : s.cloud)
  {
    top += p.normal_z > 0.5f;     // area 2 of 10
    side_x += p.normal_x > 0.5f;  // area 1 of 10
  }
  EXPECT_NEAR (top / 40000.0, 0.2, 0.01);
  EXPECT_NEAR (side_x / 40000.0, 0.1, 0.01);

  const SampledCloud g = sampleDensityGradient (box, 40000, 0, 0.1f, 3);
  int low = 0, high = 0;
  for (const auto& p : g.cloud)
  {
    low += p.x < -0.5f;
    high += p.x > 0.5f;
  }
  // Density d(x) = 1 − 0.9·(x+1)/2. x < −0.5 holds the −x face (area 1, d = 1) and strips of
  // area 2 with mean d 0.8875; x > 0.5 the +x face (d = 0.1) and strips with mean d 0.2125.
  EXPECT_NEAR (double (low) / high, (1 + 2 * 0.8875) / (0.1 + 2 * 0.2125), 0.3);
  EXPECT_THROW (sampleDensityGradient (box, 10, 3, 0.5f), std::invalid_argument);
  EXPECT_THROW (sampleDensityGradient (box, 10, 0, 0.f), std::invalid_argument);
  EXPECT_THROW (sampleUniform (TriangleMesh (), 10), std::invalid_argument);
}

TEST (Degradation, GaussianNoiseHasRequestedSigma)
{
  const TriangleMesh m = makeBox (Eigen::Vector3f (1, 1, 1), 2);
  SampledCloud s = sampleUniform (m, 50000, 5);
  const SampledCloud clean = s;
  addGaussianNoise (s, 0.01f, 9);
  const double sigma = 0.01 * std::sqrt (3.0);
  double sum2 = 0;
  for (std::size_t i = 0; i < s.cloud.size (); ++i)
    sum2 += (s.cloud[i].getVector3fMap () - clean.cloud[i].getVector3fMap ()).squaredNorm ();
  EXPECT_NEAR (std::sqrt (sum2 / (3.0 * s.cloud.size ())), sigma, 0.02 * sigma);
  EXPECT_THROW (addGaussianNoise (s, -1.f), std::invalid_argument);
}

TEST (Degradation, ShadowRemovesRequestedFractionAsCompactHoles)
{
  const TriangleMesh m = makeSphere (1.f, 4);
  for (float fraction : {0.f, 0.01f, 0.1f, 0.5f, 0.75f})
  {
    SampledCloud s = sampleUniform (m, 20000, 11);
    const std::size_t removed = applyShadowHoles (s, fraction, 4);
    EXPECT_EQ (removed, std::size_t (std::lround (fraction * 20000)));
    EXPECT_EQ (s.cloud.size (), 20000u - removed);
    EXPECT_EQ (s.face.size (), s.cloud.size ());
  }
  // Holes are compact: after removing 10 % in 1 % holes, a removed region is empty of
  // samples, so some surface point has its nearest sample much farther than usual.
  SampledCloud s = sampleUniform (m, 20000, 11);
  applyShadowHoles (s, 0.1f, 4, 0.01f);
  const SampledCloud dense = sampleUniform (m, 20000, 99);
  float worst_gap = 0;
  for (std::size_t i = 0; i < dense.cloud.size (); i += 10)
  {
    float best = 1e9f;
    for (const auto& q : s.cloud)
      best = std::min (best, (q.getVector3fMap () - dense.cloud[i].getVector3fMap ()).squaredNorm ());
    worst_gap = std::max (worst_gap, best);
  }
  // Mean spacing of 20k samples on the unit sphere is ~0.025; a 200-point hole has radius ~0.2.
  EXPECT_GT (std::sqrt (worst_gap), 0.1f);
  EXPECT_THROW (applyShadowHoles (s, 1.5f), std::invalid_argument);
}

TEST (SetScores, PrecisionRecallF1AndJaccard)
{
  const std::vector<bool> truth{true, true, false, false, true};
  const SubsetScore s = scoreSubset (std::vector<int>{0, 2, 4}, truth);  // tp 2, fp 1, fn 1
  EXPECT_EQ (s.predicted, 3u);
  EXPECT_DOUBLE_EQ (s.precision, 2.0 / 3.0);
  EXPECT_DOUBLE_EQ (s.recall, 2.0 / 3.0);
  EXPECT_DOUBLE_EQ (s.f1, 2.0 / 3.0);
  EXPECT_DOUBLE_EQ (scoreSubset (std::vector<int>{}, truth).f1, 0.0);
  EXPECT_DOUBLE_EQ (jaccard (std::vector<int>{3, 1, 2}, std::vector<int>{2, 3, 4}), 0.5);
  EXPECT_DOUBLE_EQ (jaccard (std::vector<int>{}, std::vector<int>{}), 1.0);
}
