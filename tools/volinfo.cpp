// volinfo: what a GrainTwin .h5 file holds: kind, schema, datasets, image geometry and value range,
// and the provenance history. --json prints the same on stdout for scripts.
//   volinfo scan.h5
//   volinfo labels.h5 --json | python3 -c 'import json,sys; print(json.load(sys.stdin)["kind"])'
#include <nlohmann/json.hpp>

#include <iostream>

#include "graintwin/cli/tool.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/core/interrupt.hpp"
#include "graintwin/core/volume_ops.hpp"
#include "graintwin/io/provenance.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/volume_io.hpp"

namespace fs = std::filesystem;
using namespace graintwin;
using nlohmann::json;

namespace {

// Value range of an image dataset, read in z slabs so a large volume never sits in memory whole.
template <class T>
ValueRange slab_range(const io::H5File& f, const std::string& path, const io::ImageHeader& h, cli::RunContext& ctx) {
  const std::size_t slab = std::max<std::size_t>(1, (64u << 20) / std::max<std::size_t>(1, h.shape[1] * h.shape[2] * sizeof(T)));
  std::vector<T> buf;
  ValueRange total;
  double sum = 0.0;
  std::size_t finite = 0;
  bool first = true;
  auto progress = ctx.progress("value range " + path, h.shape[0]);
  for (std::size_t z = 0; z < h.shape[0]; z += slab) {
    const std::size_t nz = std::min(slab, h.shape[0] - z);
    buf.resize(nz * h.shape[1] * h.shape[2]);
    f.read_box(path, {z, 0, 0}, {nz, h.shape[1], h.shape[2]}, buf.data());
    const ValueRange r = value_range(buf.data(), buf.size());
    const std::size_t n = buf.size() - r.non_finite;
    if (n > 0) {
      total.min = first ? r.min : std::min(total.min, r.min);
      total.max = first ? r.max : std::max(total.max, r.max);
      first = false;
    }
    sum += r.mean * static_cast<double>(n);
    finite += n;
    total.non_finite += r.non_finite;
    progress->advance(nz);
    throw_if_interrupted();
  }
  total.mean = finite ? sum / static_cast<double>(finite) : 0.0;
  return total;
}

ValueRange image_range(const io::H5File& f, const std::string& path, const io::ImageHeader& h, cli::RunContext& ctx) {
  switch (h.dtype) {
    case DType::uint8: return slab_range<std::uint8_t>(f, path, h, ctx);
    case DType::uint16: return slab_range<std::uint16_t>(f, path, h, ctx);
    case DType::uint32: return slab_range<std::uint32_t>(f, path, h, ctx);
    case DType::float32: return slab_range<float>(f, path, h, ctx);
  }
  return {};
}

void list_datasets(const io::H5File& f, const std::string& group, json& out) {
  for (const auto& name : f.list(group)) {
    const std::string p = (group == "/" ? "" : group) + "/" + name;
    if (f.is_group(p)) {
      list_datasets(f, p, out);
    } else {
      const io::DatasetInfo di = f.info(p);
      json d = {{"path", p}, {"shape", di.dims}, {"dtype", di.dtype}};
      if (auto u = f.attr_string(p, schema::attr::units)) d["units"] = *u;
      out.push_back(d);
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  cli::Tool tool("volinfo",
                 "Describe a GrainTwin HDF5 file: kind, schema version, every dataset with shape, type and "
                 "units, the geometry and value range of image datasets, and the provenance history (how "
                 "the file was made).");
  fs::path input;
  bool as_json = false, no_range = false;
  tool.add_input("file", input, "Any GrainTwin .h5 file");
  tool.cli().add_flag("--json", as_json, "Print JSON on stdout (for scripts) instead of text");
  tool.cli().add_flag("--no-range", no_range, "Skip the value range (it reads every voxel)");
  tool.set_examples({"volinfo scan.h5", "volinfo scan.h5 --json"});

  return tool.run(argc, argv, [&](cli::RunContext& ctx) {
    const io::H5File f = io::H5File::open(input);
    json info;
    info["file"] = input.string();
    const std::string kind = io::file_kind(f);
    if (kind.empty())
      throw UsageError(input.string() + " is an HDF5 file without a GrainTwin 'kind' attribute; import images with volconvert");
    info["kind"] = kind;
    info["schema_version"] = f.attr_int(schema::path::root, schema::attr::schema_version).value_or(0);
    info["creator"] = f.attr_string(schema::path::root, schema::attr::creator).value_or("");
    info["datasets"] = json::array();
    list_datasets(f, "/", info["datasets"]);
    info["images"] = json::array();
    for (const char* p : {schema::path::volume, schema::path::labels}) {
      if (!f.exists(p)) continue;
      const io::ImageHeader h = io::read_image_header(f, p);
      json im = {{"path", p},
                 {"shape_zyx", h.shape},
                 {"dtype", dtype_name(h.dtype)},
                 {"voxel_size_m_zyx", h.voxel_size},
                 {"origin_m_zyx", h.origin},
                 {"units", h.units}};
      if (!no_range) {
        const ValueRange r = image_range(f, p, h, ctx);
        im["min"] = r.min;
        im["max"] = r.max;
        im["mean"] = r.mean;
        im["non_finite"] = r.non_finite;
      }
      info["images"].push_back(im);
    }
    info["history"] = io::read_history(f);

    if (as_json) {
      std::cout << info.dump(2) << "\n";
      return;
    }
    std::cout << "file:            " << input.string() << "\n"
              << "kind:            " << kind << " (schema " << info["schema_version"] << ", " << info["creator"].get<std::string>() << ")\n";
    for (const auto& im : info["images"]) {
      const auto s = im["shape_zyx"];
      const auto vs = im["voxel_size_m_zyx"];
      std::cout << "image " << im["path"].get<std::string>() << ":\n"
                << "  shape (z,y,x):   " << s[0] << " x " << s[1] << " x " << s[2] << "\n"
                << "  dtype:           " << im["dtype"].get<std::string>() << "\n"
                << "  voxel size:      " << vs[0].get<double>() * 1e6 << " x " << vs[1].get<double>() * 1e6 << " x "
                << vs[2].get<double>() * 1e6 << " um (z,y,x)\n"
                << "  origin (z,y,x):  " << im["origin_m_zyx"].dump() << " m\n";
      if (im.contains("min"))
        std::cout << "  values:          " << im["min"].get<double>() << " .. " << im["max"].get<double>()
                  << ", mean " << im["mean"].get<double>()
                  << (im["non_finite"].get<std::size_t>() ? ", " + std::to_string(im["non_finite"].get<std::size_t>()) + " NaN/Inf" : "")
                  << "\n";
    }
    std::cout << "datasets:\n";
    for (const auto& d : info["datasets"]) {
      std::cout << "  " << d["path"].get<std::string>() << "  " << d["dtype"].get<std::string>() << " " << d["shape"].dump();
      if (d.contains("units")) std::cout << "  [" << d["units"].get<std::string>() << "]";
      std::cout << "\n";
    }
    std::cout << "history:\n";
    for (const auto& l : info["history"]) std::cout << "  " << l.get<std::string>() << "\n";
  });
}
