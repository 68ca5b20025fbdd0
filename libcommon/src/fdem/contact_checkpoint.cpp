// The contact model's checkpoint: tangential spring histories (grain pairs and membrane balls) and
// the last step's contact records, saved and loaded with their consistency checks.
#include <fmt/format.h>

#include <cmath>

#include "contact_state.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/io/h5file.hpp"
#include "graintwin/io/schema.hpp"

namespace graintwin::fdem {
namespace ck = schema::fdem_checkpoint;

void ContactModel::save(io::H5File& file, const std::string& group) const {
  const State& s = *state_;
  file.ensure_group(group);
  file.set_attr(group, ck::history_entries, static_cast<long long>(s.history.size()));
  file.set_attr(group, ck::ball_entries, static_cast<long long>(s.ball_history.size()));
  file.set_attr(group, ck::record_entries, static_cast<long long>(s.records.size()));
  file.set_attr(group, ck::deep_pair_entries, static_cast<long long>(s.deep_pairs.size()));
  if (!s.deep_pairs.empty()) {  // the pairs whose kept initial overlaps the search reaches
    std::vector<std::uint32_t> pair(2 * s.deep_pairs.size());
    std::vector<double> depth(s.deep_pairs.size());
    for (std::size_t i = 0; i < s.deep_pairs.size(); ++i)
      pair[2 * i] = s.deep_pairs[i].a, pair[2 * i + 1] = s.deep_pairs[i].b, depth[i] = s.deep_pairs[i].depth;
    const hsize_t n = s.deep_pairs.size();
    file.write(group + "/" + ck::deep_pair, pair.data(), {n, 2});
    file.write(group + "/" + ck::deep_pair_depth, depth.data(), {n}, io::units("m"));
  }
  if (!s.records.empty()) {  // the last step's contacts, for a frame written before the next step
    std::vector<std::uint32_t> pair(2 * s.records.size());
    std::vector<double> values;
    values.reserve(11 * s.records.size());
    for (std::size_t i = 0; i < s.records.size(); ++i) {
      const ContactRecord& r = s.records[i];
      pair[2 * i] = r.a;
      pair[2 * i + 1] = r.b;
      values.insert(values.end(), {r.point[0], r.point[1], r.point[2], r.normal[0], r.normal[1], r.normal[2], r.force[0],
                                   r.force[1], r.force[2], r.overlap, r.stiffness});
    }
    const hsize_t n = s.records.size();
    io::DatasetOptions exact;
    exact.compress = false;
    file.write(group + "/" + ck::record_pair, pair.data(), {n, 2});
    file.write(group + "/" + ck::record_values, values.data(), {n, 11}, exact);
  }
  if (!s.history.empty()) {
    std::vector<std::uint32_t> pair(2 * s.history.size()), node(s.history.size());
    std::vector<double> spring(3 * s.history.size()), offset(s.history.size());
    for (std::size_t i = 0; i < s.history.size(); ++i) {
      const HistoryEntry& h = s.history[i];
      pair[2 * i] = h.a;
      pair[2 * i + 1] = h.b;
      node[i] = h.node;
      for (int k = 0; k < 3; ++k) spring[3 * i + k] = h.spring[k];
      offset[i] = h.offset;
    }
    const hsize_t n = s.history.size();
    file.write(group + "/" + ck::history_pair, pair.data(), {n, 2});
    file.write(group + "/" + ck::history_node, node.data(), {n});
    file.write(group + "/" + ck::history_spring, spring.data(), {n, 3}, io::units("N"));
    file.write(group + "/" + ck::history_offset, offset.data(), {n}, io::units("m"));
  }
  if (!s.ball_history.empty()) {  // membrane balls' friction springs
    std::vector<std::uint32_t> ball_grain(2 * s.ball_history.size());
    std::vector<double> spring(3 * s.ball_history.size());
    for (std::size_t i = 0; i < s.ball_history.size(); ++i) {
      const BallHistoryEntry& h = s.ball_history[i];
      ball_grain[2 * i] = h.ball;
      ball_grain[2 * i + 1] = h.grain;
      for (int k = 0; k < 3; ++k) spring[3 * i + k] = h.spring[k];
    }
    const hsize_t n = s.ball_history.size();
    file.write(group + "/" + ck::ball_grain, ball_grain.data(), {n, 2});
    file.write(group + "/" + ck::ball_spring, spring.data(), {n, 3}, io::units("N"));
  }
}

void ContactModel::load(const io::H5File& file, const std::string& group) {
  State& s = *state_;
  auto bad = [&](const std::string& why) {
    return DataError(fmt::format("{}: the contact history in {} {}; write the checkpoint with this model.",
                                 file.path().string(), group, why));
  };
  const auto entries = file.attr_int(group, ck::history_entries);
  if (!entries || *entries < 0) throw bad("has no 'entries' count");
  // Each count is checked against its tables before it sizes anything: a damaged count must
  // not allocate (a record_entries of 2^32 asked for 377 GB).
  std::vector<HistoryEntry> history;
  if (*entries > 0) {
    std::vector<hsize_t> pair_dims, node_dims, spring_dims;
    const auto pair = file.read<std::uint32_t>(group + "/" + ck::history_pair, &pair_dims);
    const auto node = file.read<std::uint32_t>(group + "/" + ck::history_node, &node_dims);
    const auto spring = file.read<double>(group + "/" + ck::history_spring, &spring_dims);
    const auto n = static_cast<hsize_t>(*entries);
    if (pair_dims != std::vector<hsize_t>{n, 2} || node_dims != std::vector<hsize_t>{n} ||
        spring_dims != std::vector<hsize_t>{n, 3})
      throw bad(fmt::format("does not hold {} entries in pair (n x 2), node (n) and spring (n x 3)", n));
    // Checkpoints written before initial overlaps could be kept have no offsets: none were kept.
    std::vector<double> offset(n, 0.0);
    if (file.exists(group + "/" + ck::history_offset)) {
      std::vector<hsize_t> offset_dims;
      offset = file.read<double>(group + "/" + ck::history_offset, &offset_dims);
      if (offset_dims != std::vector<hsize_t>{n}) throw bad(fmt::format("does not hold {} entries in offset (n)", n));
    }
    history.resize(n);
    for (std::size_t i = 0; i < history.size(); ++i)
      history[i] = {pair[2 * i], pair[2 * i + 1], node[i], {spring[3 * i], spring[3 * i + 1], spring[3 * i + 2]}, offset[i]};
  }
  for (std::size_t i = 0; i < history.size(); ++i) {
    const HistoryEntry& h = history[i];
    if (h.a >= s.grains.size() || h.b <= h.a || h.node >= s.node_count)
      throw bad(fmt::format("names grain pair ({}, {}) and node {} outside a model of {} grains and {} nodes", h.a,
                            h.b, h.node, s.grains.size(), s.node_count));
    if (i > 0 && !key_less(history[i - 1], h.a, h.b, h.node)) throw bad("is not sorted by pair and node");
  }
  const auto ball_entries = file.attr_int(group, ck::ball_entries).value_or(0);
  if (ball_entries < 0) throw bad("has a negative 'ball_entries' count");
  std::vector<BallHistoryEntry> ball_history;
  if (ball_entries > 0) {
    std::vector<hsize_t> pair_dims, spring_dims;
    const auto ball_grain = file.read<std::uint32_t>(group + "/" + ck::ball_grain, &pair_dims);
    const auto spring = file.read<double>(group + "/" + ck::ball_spring, &spring_dims);
    const auto n = static_cast<hsize_t>(ball_entries);
    if (pair_dims != std::vector<hsize_t>{n, 2} || spring_dims != std::vector<hsize_t>{n, 3})
      throw bad(fmt::format("does not hold {} ball entries in ball_grain (n x 2) and ball_spring (n x 3)", n));
    ball_history.resize(n);
    for (std::size_t i = 0; i < ball_history.size(); ++i) {
      ball_history[i] = {ball_grain[2 * i], ball_grain[2 * i + 1], {spring[3 * i], spring[3 * i + 1], spring[3 * i + 2]}};
      const BallHistoryEntry& h = ball_history[i];
      if (h.grain >= s.grains.size()) throw bad(fmt::format("names grain {} of a model of {} grains", h.grain, s.grains.size()));
      if (i > 0 && std::make_pair(ball_history[i - 1].ball, ball_history[i - 1].grain) >= std::make_pair(h.ball, h.grain))
        throw bad("is not sorted by ball and grain");
    }
  }
  const auto record_entries = file.attr_int(group, ck::record_entries).value_or(0);
  if (record_entries < 0) throw bad("has a negative 'record_entries' count");
  std::vector<ContactRecord> records;
  if (record_entries > 0) {
    std::vector<hsize_t> pair_dims, value_dims;
    const auto pair = file.read<std::uint32_t>(group + "/" + ck::record_pair, &pair_dims);
    const auto values = file.read<double>(group + "/" + ck::record_values, &value_dims);
    const auto n = static_cast<hsize_t>(record_entries);
    // Checkpoints written before the records held their stiffness have 10 columns (stiffness 0).
    const hsize_t columns = value_dims.size() == 2 ? value_dims[1] : 0;
    if (pair_dims != std::vector<hsize_t>{n, 2} || value_dims.size() != 2 || value_dims[0] != n ||
        (columns != 10 && columns != 11))
      throw bad(fmt::format("does not hold {} contact records in record_pair (n x 2) and record_values (n x 11)", n));
    records.resize(n);
    for (std::size_t i = 0; i < records.size(); ++i) {
      const double* v = values.data() + columns * i;
      records[i] = {pair[2 * i], pair[2 * i + 1], {v[0], v[1], v[2]}, {v[3], v[4], v[5]}, {v[6], v[7], v[8]}, v[9],
                    columns == 11 ? v[10] : 0.0};
      // A servo reads the stiffness: a negative or non-finite one would stall or free it.
      if (!(records[i].stiffness >= 0) || !std::isfinite(records[i].stiffness))
        throw bad(fmt::format("has contact record {} with stiffness {} (must be finite and >= 0)", i, records[i].stiffness));
    }
  }
  // Checkpoints written before initial overlaps could be kept have none.
  const auto deep_entries = file.attr_int(group, ck::deep_pair_entries).value_or(0);
  if (deep_entries < 0) throw bad("has a negative 'deep_pair_entries' count");
  std::vector<DeepPair> deep_pairs;
  if (deep_entries > 0) {
    std::vector<hsize_t> pair_dims, depth_dims;
    const auto pair = file.read<std::uint32_t>(group + "/" + ck::deep_pair, &pair_dims);
    const auto depth = file.read<double>(group + "/" + ck::deep_pair_depth, &depth_dims);
    const auto n = static_cast<hsize_t>(deep_entries);
    if (pair_dims != std::vector<hsize_t>{n, 2} || depth_dims != std::vector<hsize_t>{n})
      throw bad(fmt::format("does not hold {} deep pairs in deep_pair (n x 2) and deep_pair_depth (n)", n));
    deep_pairs.resize(n);
    for (std::size_t i = 0; i < deep_pairs.size(); ++i) {
      deep_pairs[i] = {pair[2 * i], pair[2 * i + 1], depth[i]};
      const DeepPair& d = deep_pairs[i];
      if (d.a >= s.grains.size() || d.b <= d.a || d.b >= s.grains.size() || !(d.depth > 0) || !std::isfinite(d.depth))
        throw bad(fmt::format("names grain pair ({}, {}) with search depth {} outside a model of {} grains", d.a, d.b, d.depth,
                              s.grains.size()));
      if (i > 0 && std::tie(deep_pairs[i - 1].a, deep_pairs[i - 1].b) >= std::tie(d.a, d.b)) throw bad("has deep pairs not sorted by pair");
    }
  }
  s.history = std::move(history);
  s.deep_pairs = std::move(deep_pairs);
  s.ball_history = std::move(ball_history);
  s.records = std::move(records);
  s.need_rebuild = true;
  s.overlap_configuration = false;
}

}  // namespace graintwin::fdem
