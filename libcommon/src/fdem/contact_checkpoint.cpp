// The contact model's checkpoint: tangential spring histories (grain pairs and membrane balls) and
// the last step's contact records, saved and loaded with their consistency checks.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <tuple>

#include "contact_state.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/io/h5file.hpp"
#include "graintwin/io/schema.hpp"

namespace graintwin::fdem {
namespace ck = schema::fdem_checkpoint;

void ContactModel::save(io::H5File& file, const std::string& group, const CheckpointPart& part) const {
  const State& s = *state_;
  const auto held = [&](std::uint32_t a) { return !part.grains || std::binary_search(part.grains->begin(), part.grains->end(), a); };
  std::vector<ContactRecord> records;
  std::vector<HistoryEntry> history;
  for (const ContactRecord& r : s.records)
    if (held(r.a)) records.push_back(r);
  for (const HistoryEntry& h : s.history)
    if (held(h.a)) history.push_back(h);
  const std::vector<BallHistoryEntry> no_balls;
  const std::vector<DeepPair> no_deep_pairs;
  const std::vector<BallHistoryEntry>& ball_history = part.shared ? s.ball_history : no_balls;
  const std::vector<DeepPair>& deep_pairs = part.shared ? s.deep_pairs : no_deep_pairs;
  file.ensure_group(group);
  file.set_attr(group, ck::history_entries, static_cast<long long>(history.size()));
  file.set_attr(group, ck::ball_entries, static_cast<long long>(ball_history.size()));
  file.set_attr(group, ck::record_entries, static_cast<long long>(records.size()));
  file.set_attr(group, ck::deep_pair_entries, static_cast<long long>(deep_pairs.size()));
  if (!deep_pairs.empty()) {  // the pairs whose kept initial overlaps the search reaches
    std::vector<std::uint32_t> pair(2 * deep_pairs.size());
    std::vector<double> depth(deep_pairs.size());
    for (std::size_t i = 0; i < deep_pairs.size(); ++i)
      pair[2 * i] = deep_pairs[i].a, pair[2 * i + 1] = deep_pairs[i].b, depth[i] = deep_pairs[i].depth;
    const hsize_t n = deep_pairs.size();
    file.write(group + "/" + ck::deep_pair, pair.data(), {n, 2});
    file.write(group + "/" + ck::deep_pair_depth, depth.data(), {n}, io::units("m"));
  }
  if (!records.empty()) {  // the last step's contacts, for a frame written before the next step
    std::vector<std::uint32_t> pair(2 * records.size());
    std::vector<double> values;
    values.reserve(11 * records.size());
    for (std::size_t i = 0; i < records.size(); ++i) {
      const ContactRecord& r = records[i];
      pair[2 * i] = r.a;
      pair[2 * i + 1] = r.b;
      values.insert(values.end(), {r.point[0], r.point[1], r.point[2], r.normal[0], r.normal[1], r.normal[2], r.force[0],
                                   r.force[1], r.force[2], r.overlap, r.stiffness});
    }
    const hsize_t n = records.size();
    io::DatasetOptions exact;
    exact.compress = false;
    file.write(group + "/" + ck::record_pair, pair.data(), {n, 2});
    file.write(group + "/" + ck::record_values, values.data(), {n, 11}, exact);
  }
  if (!history.empty()) {
    std::vector<std::uint32_t> pair(2 * history.size()), node(history.size());
    std::vector<double> spring(3 * history.size()), offset(history.size());
    for (std::size_t i = 0; i < history.size(); ++i) {
      const HistoryEntry& h = history[i];
      pair[2 * i] = h.a;
      pair[2 * i + 1] = h.b;
      node[i] = h.node;
      for (int k = 0; k < 3; ++k) spring[3 * i + k] = h.spring[k];
      offset[i] = h.offset;
    }
    const hsize_t n = history.size();
    file.write(group + "/" + ck::history_pair, pair.data(), {n, 2});
    file.write(group + "/" + ck::history_node, node.data(), {n});
    file.write(group + "/" + ck::history_spring, spring.data(), {n, 3}, io::units("N"));
    file.write(group + "/" + ck::history_offset, offset.data(), {n}, io::units("m"));
  }
  if (!ball_history.empty()) {  // membrane balls' friction springs
    std::vector<std::uint32_t> ball_grain(2 * ball_history.size());
    std::vector<double> spring(3 * ball_history.size());
    for (std::size_t i = 0; i < ball_history.size(); ++i) {
      const BallHistoryEntry& h = ball_history[i];
      ball_grain[2 * i] = h.ball;
      ball_grain[2 * i + 1] = h.grain;
      for (int k = 0; k < 3; ++k) spring[3 * i + k] = h.spring[k];
    }
    const hsize_t n = ball_history.size();
    file.write(group + "/" + ck::ball_grain, ball_grain.data(), {n, 2});
    file.write(group + "/" + ck::ball_spring, spring.data(), {n, 3}, io::units("N"));
  }
}

namespace {

/// A DataError naming the file and the table at fault.
DataError bad_history(const io::H5File& file, const std::string& group, const std::string& why) {
  return DataError(fmt::format("{}: the contact history in {} {}; write the checkpoint with this model.", file.path().string(),
                               group, why));
}

}  // namespace

std::vector<HistoryEntry> ContactModel::State::read_history(const io::H5File& file, const std::string& group) const {
  auto bad = [&](const std::string& why) { return bad_history(file, group, why); };
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
    if (h.a >= grains.size() || h.b <= h.a || h.node >= node_count)
      throw bad(fmt::format("names grain pair ({}, {}) and node {} outside a model of {} grains and {} nodes", h.a,
                            h.b, h.node, grains.size(), node_count));
    if (i > 0 && !key_less(history[i - 1], h.a, h.b, h.node)) throw bad("is not sorted by pair and node");
  }
  return history;
}

std::vector<ContactRecord> ContactModel::State::read_records(const io::H5File& file, const std::string& group) const {
  auto bad = [&](const std::string& why) { return bad_history(file, group, why); };
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
  return records;
}

void ContactModel::load(const io::H5File& file, const std::string& group) {
  const io::H5File* one[] = {&file};
  load(one, group);
}

void ContactModel::load(std::span<const io::H5File* const> files, const std::string& group) {
  State& s = *state_;
  const io::H5File& file = *files.front();  // the shared state's
  auto bad = [&](const std::string& why) { return bad_history(file, group, why); };
  std::vector<HistoryEntry> history;
  std::vector<ContactRecord> records;
  for (const io::H5File* part : files) {
    std::vector<HistoryEntry> h = s.read_history(*part, group);
    std::vector<ContactRecord> r = s.read_records(*part, group);
    history.insert(history.end(), h.begin(), h.end());
    records.insert(records.end(), r.begin(), r.end());
  }
  if (files.size() > 1) {  // each part's in the one-rank order: all of them in it
    std::stable_sort(history.begin(), history.end(),
                     [](const HistoryEntry& p, const HistoryEntry& q) { return key_less(p, q.a, q.b, q.node); });
    for (std::size_t i = 1; i < history.size(); ++i)
      if (!key_less(history[i - 1], history[i].a, history[i].b, history[i].node))
        throw bad(fmt::format("and its parts both hold node {} of grain pair ({}, {}); rewrite the checkpoint", history[i].node,
                              history[i].a, history[i].b));
    std::stable_sort(records.begin(), records.end(),
                     [](const ContactRecord& p, const ContactRecord& q) { return std::tie(p.a, p.b) < std::tie(q.a, q.b); });
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
