// Reference for ct2labels_bench: the ct2labels chain (docs/methods.md, segmentation) built from ITK 5.2 filters
// (Debian libinsighttoolkit5-dev) as an ITK user would write it, one filter per step, each updated
// and timed on its own, intermediates released as soon as the next step has its input (ITK's best
// memory, not a pipeline that keeps every output alive):
//   DiscreteGaussianImageFilter (sigma SIGMA_VOX voxels, GrainTwin's default denoising) ->
//   OtsuThresholdImageFilter (one bin per grey value, whole volume) ->
//   BinaryFillholeImageFilter -> SignedMaurerDistanceMapImageFilter -> HMaximaImageFilter ->
//   RegionalMaximaImageFilter -> ConnectedComponentImageFilter (markers) ->
//   MorphologicalWatershedFromMarkersImageFilter on -EDT -> MaskImageFilter (the solid).
// The signed map is clamped to 0 on the void (the EDT of the solid, as the other implementations
// have it); without that ITK's flood sorts every distinct void distance and takes 2-3x longer.
// Input is a MetaImage copy of the scan (ITK's HDF5 reader expects ITK's own layout, not GrainTwin's);
// reading and writing are timed separately from the segmentation.
//   itk_segment SCAN.mhd LABELS.mhd TIMES.json H_VOX THREADS SIGMA_VOX
#include <cmath>

#include <itkBinaryFillholeImageFilter.h>
#include <itkConnectedComponentImageFilter.h>
#include <itkHMaximaImageFilter.h>
#include <itkImageFileReader.h>
#include <itkImageFileWriter.h>
#include <itkMaskImageFilter.h>
#include <itkDiscreteGaussianImageFilter.h>
#include <itkMinimumMaximumImageCalculator.h>
#include <itkMorphologicalWatershedFromMarkersImageFilter.h>
#include <itkMultiThreaderBase.h>
#include <itkOtsuThresholdImageFilter.h>
#include <itkRegionalMaximaImageFilter.h>
#include <itkSignedMaurerDistanceMapImageFilter.h>

#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <fstream>
#include <iostream>
#include <string>
#include <utility>
#include <vector>

using Grey = itk::Image<std::uint16_t, 3>;
using Mask = itk::Image<std::uint8_t, 3>;
using Real = itk::Image<float, 3>;
using Labels = itk::Image<std::uint32_t, 3>;

namespace {

/// CPU time of this process (all threads), a check on contention from other work.
double cpu_seconds() {
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  return ru.ru_utime.tv_sec + ru.ru_stime.tv_sec + 1e-6 * (ru.ru_utime.tv_usec + ru.ru_stime.tv_usec);
}

class Steps {
 public:
  template <class F>
  void time(const std::string& name, F&& f) {
    const auto t0 = std::chrono::steady_clock::now();
    f();
    steps_.emplace_back(name, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  void write(const std::string& path, double cpu, double threshold, std::size_t markers) const {
    std::ofstream out(path);
    out << "{\"steps\": {";
    for (std::size_t i = 0; i < steps_.size(); ++i)
      out << (i ? ", " : "") << '"' << steps_[i].first << "\": " << steps_[i].second;
    out << "}, \"cpu\": " << cpu << ", \"threshold\": " << threshold << ", \"markers\": " << markers << "}\n";
  }

 private:
  std::vector<std::pair<std::string, double>> steps_;
};

/// Runs a filter and returns its output detached from the pipeline, so the filter (and its input,
/// if nothing else holds it) can be freed.
template <class Filter>
typename Filter::OutputImageType::Pointer run(typename Filter::Pointer f) {
  f->Update();
  typename Filter::OutputImageType::Pointer out = f->GetOutput();
  out->DisconnectPipeline();
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 7) {
    std::cerr << "usage: itk_segment SCAN.mhd LABELS.mhd TIMES.json H_VOX THREADS SIGMA_VOX\n";
    return 2;
  }
  const std::string in_path = argv[1], out_path = argv[2], times_path = argv[3];
  const double h_vox = std::stod(argv[4]);
  const int threads = std::stoi(argv[5]);
  const double sigma_vox = std::stod(argv[6]);
  itk::MultiThreaderBase::SetGlobalMaximumNumberOfThreads(threads);
  itk::MultiThreaderBase::SetGlobalDefaultNumberOfThreads(threads);
  Steps steps;
  try {
    Grey::Pointer grey;
    steps.time("read", [&] {
      auto r = itk::ImageFileReader<Grey>::New();
      r->SetFileName(in_path);
      grey = run<itk::ImageFileReader<Grey>>(r);
    });
    const double cpu0 = cpu_seconds();
    const auto spacing = grey->GetSpacing();
    const double unit = std::min({spacing[0], spacing[1], spacing[2]});

    steps.time("denoise", [&] {
      using Gauss = itk::DiscreteGaussianImageFilter<Grey, Grey>;
      auto g = Gauss::New();
      g->SetInput(grey);
      g->SetUseImageSpacing(false);  // sigma in voxel steps, as GrainTwin's --sigma-vox
      g->SetVariance(sigma_vox * sigma_vox);
      g->SetMaximumKernelWidth(2 * static_cast<unsigned>(std::ceil(3.0 * sigma_vox)) + 1);
      g->SetMaximumError(0.001);
      grey = run<Gauss>(g);  // edges replicated (zero-flux Neumann) as GrainTwin does
    });

    Mask::Pointer solid;
    double threshold = 0.0;
    steps.time("threshold", [&] {
      auto mm = itk::MinimumMaximumImageCalculator<Grey>::New();
      mm->SetImage(grey);
      mm->Compute();
      using Otsu = itk::OtsuThresholdImageFilter<Grey, Mask>;
      auto o = Otsu::New();
      o->SetInput(grey);
      // One bin per grey value, as GrainTwin and the scikit-image reference do for integer scans.
      o->SetNumberOfHistogramBins(static_cast<unsigned>(mm->GetMaximum() - mm->GetMinimum()) + 1);
      o->SetInsideValue(0);  // ITK's "inside" is [min, threshold]: the void
      o->SetOutsideValue(1);
      solid = run<Otsu>(o);
      threshold = o->GetThreshold();
    });
    grey = nullptr;

    steps.time("fill holes", [&] {
      using Fill = itk::BinaryFillholeImageFilter<Mask>;
      auto f = Fill::New();
      f->SetInput(solid);
      f->SetForegroundValue(1);
      f->SetFullyConnected(false);  // holes are 6-connected background, as in GrainTwin
      solid = run<Fill>(f);
    });

    Real::Pointer edt;
    steps.time("distance transform", [&] {
      // Maurer on the void (the void is "inside"): a solid voxel's value is its distance to the
      // nearest void voxel centre, the EDT of the solid exactly (on the solid itself ITK would
      // measure to the solid's own boundary voxels, one voxel short).
      using Maurer = itk::SignedMaurerDistanceMapImageFilter<Mask, Real>;
      auto m = Maurer::New();
      m->SetInput(solid);
      m->SetBackgroundValue(1);  // the solid is background: distances are measured to the void
      m->SetInsideIsPositive(false);
      m->SetUseImageSpacing(true);
      m->SetSquaredDistance(false);
      edt = run<Maurer>(m);
      // The void holds negative distances (to the solid); the chain needs the EDT of the solid, 0 on
      // the void, as scipy and GrainTwin give: one flat void level also keeps the reconstruction and
      // the flood below from sorting millions of distinct void values.
      float* d = edt->GetBufferPointer();
      const std::size_t n = edt->GetLargestPossibleRegion().GetNumberOfPixels();
      for (std::size_t i = 0; i < n; ++i) d[i] = std::max(d[i], 0.0f);
    });

    Labels::Pointer markers;
    std::size_t n_markers = 0;
    steps.time("markers", [&] {
      using HMax = itk::HMaximaImageFilter<Real, Real>;
      auto hm = HMax::New();
      hm->SetInput(edt);
      hm->SetHeight(static_cast<float>(h_vox * unit));
      hm->SetFullyConnected(true);
      Real::Pointer rec = run<HMax>(hm);
      using RMax = itk::RegionalMaximaImageFilter<Real, Mask>;
      auto rm = RMax::New();
      rm->SetInput(rec);
      rm->SetFullyConnected(true);
      rm->SetForegroundValue(1);
      rm->SetBackgroundValue(0);
      rm->SetFlatIsMaxima(false);
      Mask::Pointer peaks = run<RMax>(rm);
      rec = nullptr;
      using CC = itk::ConnectedComponentImageFilter<Mask, Labels, Mask>;
      auto cc = CC::New();
      cc->SetInput(peaks);
      cc->SetMaskImage(solid);  // maxima in the void are not grains
      cc->SetFullyConnected(true);
      markers = run<CC>(cc);
      n_markers = cc->GetObjectCount();
    });

    Labels::Pointer labels;
    steps.time("watershed", [&] {
      // Watershed of -EDT: negate in place (the EDT is not needed afterwards).
      float* d = edt->GetBufferPointer();
      const std::size_t n = edt->GetLargestPossibleRegion().GetNumberOfPixels();
      for (std::size_t i = 0; i < n; ++i) d[i] = -d[i];
      using WS = itk::MorphologicalWatershedFromMarkersImageFilter<Real, Labels>;
      auto ws = WS::New();
      ws->SetInput(edt);
      ws->SetMarkerImage(markers);
      ws->SetMarkWatershedLine(false);
      ws->SetFullyConnected(true);
      Labels::Pointer flooded = run<WS>(ws);
      edt = nullptr;
      markers = nullptr;
      // The flood also covers the void; keep the solid only.
      using M = itk::MaskImageFilter<Labels, Mask, Labels>;
      auto mk = M::New();
      mk->SetInput(flooded);
      mk->SetMaskImage(solid);
      labels = run<M>(mk);
    });
    solid = nullptr;
    const double cpu = cpu_seconds() - cpu0;

    steps.time("write", [&] {
      auto w = itk::ImageFileWriter<Labels>::New();
      w->SetFileName(out_path);
      w->SetInput(labels);
      w->SetUseCompression(false);
      w->Update();
    });
    steps.write(times_path, cpu, threshold, n_markers);
  } catch (const itk::ExceptionObject& e) {
    std::cerr << "itk_segment: " << e.GetDescription() << "\n";
    return 1;
  }
  return 0;
}
