// GmshWorkers: gmsh in forked worker processes, one request at a time each, over a Unix socket
// pair (messages: an 8-byte length, then the fields in order, native byte order: both ends are the
// same binary).
#include <poll.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <thread>

#include <fmt/format.h>
#include <omp.h>

#include "graintwin/core/error.hpp"
#include "graintwin/core/interrupt.hpp"
#include "gmsh_request.hpp"

namespace graintwin::mesh {
namespace {

class Writer {
 public:
  template <class T>
  void put(const T& value) {
    const auto* p = reinterpret_cast<const char*>(&value);
    bytes_.insert(bytes_.end(), p, p + sizeof(T));
  }
  template <class T>
  void put_all(const std::vector<T>& values) {
    put(static_cast<std::uint64_t>(values.size()));
    const auto* p = reinterpret_cast<const char*>(values.data());
    bytes_.insert(bytes_.end(), p, p + values.size() * sizeof(T));
  }
  void put_string(const std::string& s) { put_all(std::vector<char>(s.begin(), s.end())); }
  /// The message with its length in front.
  std::vector<char> framed() const {
    const std::uint64_t n = bytes_.size();
    std::vector<char> out(sizeof n + bytes_.size());
    std::memcpy(out.data(), &n, sizeof n);
    std::copy(bytes_.begin(), bytes_.end(), out.begin() + sizeof n);
    return out;
  }

 private:
  std::vector<char> bytes_;
};

class Reader {
 public:
  explicit Reader(const std::vector<char>& bytes) : p_(bytes.data()), end_(bytes.data() + bytes.size()) {}
  template <class T>
  T get() {
    T value;
    take(&value, sizeof(T));
    return value;
  }
  template <class T>
  std::vector<T> get_all() {
    const auto n = get<std::uint64_t>();
    if (n > static_cast<std::uint64_t>(end_ - p_) / sizeof(T)) throw DataError("a gmsh worker message is shorter than it says");
    std::vector<T> values(n);
    take(values.data(), n * sizeof(T));
    return values;
  }
  std::string get_string() {
    const auto c = get_all<char>();
    return {c.begin(), c.end()};
  }

 private:
  void take(void* to, std::size_t n) {
    if (n > static_cast<std::size_t>(end_ - p_)) throw DataError("a gmsh worker message is shorter than it says");
    if (n == 0) return;  // an empty list's data() may be null, which memcpy must not be given even for 0 bytes
    std::memcpy(to, p_, n);
    p_ += n;
  }
  const char* p_;
  const char* end_;
};

// Eigen vectors of doubles are sent as flat doubles.
std::vector<double> flatten(const std::vector<Eigen::Vector3d>& points) {
  std::vector<double> out;
  out.reserve(3 * points.size());
  for (const auto& p : points) out.insert(out.end(), {p.x(), p.y(), p.z()});
  return out;
}
std::vector<Eigen::Vector3d> unflatten(const std::vector<double>& xyz) {
  std::vector<Eigen::Vector3d> out(xyz.size() / 3);
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = Eigen::Vector3d(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
  return out;
}

std::vector<char> encode_request(const detail::GmshRequest& q) {
  Writer w;
  w.put(q.body), w.put(q.size), w.put(q.order), w.put(q.fix_inverted), w.put(q.straight), w.put(q.keep_surface);
  w.put(q.semi_axes.x()), w.put(q.semi_axes.y()), w.put(q.semi_axes.z());
  w.put_all(flatten(q.surface.vertices));
  w.put_all(q.surface.triangles);
  return w.framed();
}

detail::GmshRequest decode_request(const std::vector<char>& bytes) {
  Reader r(bytes);
  detail::GmshRequest q;
  q.body = r.get<detail::GmshRequest::Body>();
  q.size = r.get<double>(), q.order = r.get<int>(), q.fix_inverted = r.get<bool>(), q.straight = r.get<bool>();
  q.keep_surface = r.get<bool>();
  for (int k = 0; k < 3; ++k) q.semi_axes[k] = r.get<double>();
  q.surface.vertices = unflatten(r.get_all<double>());
  q.surface.triangles = r.get_all<std::array<int, 3>>();
  return q;
}

enum class Status : std::uint8_t { meshed = 0, failed = 1 };

std::vector<char> encode_mesh(const TetMesh& m, const TetReport& t) {
  Writer w;
  w.put(Status::meshed);
  w.put(t.inverted_after_curving), w.put(t.optimized), w.put(t.inverted), w.put(t.straightened), w.put(t.seconds);
  w.put(m.nodes_per_element);
  w.put_all(flatten(m.nodes));
  w.put_all(m.elements);
  return w.framed();
}

std::vector<char> encode_failure(const std::string& message) {
  Writer w;
  w.put(Status::failed);
  w.put_string(message);
  return w.framed();
}

/// The mesh in a reply; the worker's DataError (its one sentence) thrown again here.
TetMesh decode_reply(const std::vector<char>& bytes, TetReport& t) {
  Reader r(bytes);
  if (r.get<Status>() == Status::failed) throw DataError(r.get_string());
  t.inverted_after_curving = r.get<std::size_t>(), t.optimized = r.get<bool>(), t.inverted = r.get<std::size_t>();
  t.straightened = r.get<std::size_t>(), t.seconds = r.get<double>();
  TetMesh m;
  m.nodes_per_element = r.get<int>();
  m.nodes = unflatten(r.get_all<double>());
  m.elements = r.get_all<std::uint32_t>();
  return m;
}

/// Sends all of `bytes`; false when the other end is gone (no SIGPIPE: MSG_NOSIGNAL).
bool send_all(int fd, const std::vector<char>& bytes) {
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::send(fd, bytes.data() + done, bytes.size() - done, MSG_NOSIGNAL);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    done += static_cast<std::size_t>(n);
  }
  return true;
}

/// Reads exactly n bytes; false at end of stream or on an error. `wait` is called before each
/// read and may throw (the parent's interrupt check).
template <class Wait>
bool receive_exactly(int fd, char* to, std::size_t n, Wait&& wait) {
  while (n > 0) {
    wait();
    const ssize_t got = ::recv(fd, to, n, 0);
    if (got < 0 && errno == EINTR) continue;
    if (got <= 0) return false;
    to += got, n -= static_cast<std::size_t>(got);
  }
  return true;
}

/// One framed message; false at end of stream.
template <class Wait>
bool receive_message(int fd, std::vector<char>& bytes, Wait&& wait) {
  std::uint64_t n = 0;
  if (!receive_exactly(fd, reinterpret_cast<char*>(&n), sizeof n, wait)) return false;
  bytes.resize(n);
  return receive_exactly(fd, bytes.data(), n, wait);
}

/// The worker: answers requests until the parent closes its end. Never returns; _exit skips the
/// parent's atexit handlers and stdio buffers (HDF5 would flush the parent's open files).
[[noreturn]] void serve(int fd, pid_t parent) {
  ::signal(SIGINT, SIG_IGN);  // Ctrl-C reaches the whole process group; the parent decides
  ::signal(SIGTERM, SIG_IGN);
  ::prctl(PR_SET_PDEATHSIG, SIGKILL);
  if (::getppid() != parent) ::_exit(1);  // the parent died before prctl
  std::vector<char> bytes;
  const auto no_wait = [] {};
  while (receive_message(fd, bytes, no_wait)) {
    std::vector<char> reply;
    try {
      TetReport report;
      const TetMesh m = detail::run_gmsh_unlocked(decode_request(bytes), report);
      reply = encode_mesh(m, report);
    } catch (const Error& e) {
      reply = encode_failure(e.message());
    } catch (const std::exception& e) {
      reply = encode_failure(fmt::format("gmsh failed ({})", e.what()));
    } catch (...) {
      reply = encode_failure("gmsh failed with an unknown exception");
    }
    if (!send_all(fd, reply)) ::_exit(1);
  }
  ::_exit(0);
}

std::string describe(int status) {
  if (WIFSIGNALED(status)) return fmt::format("was killed by signal {} ({})", WTERMSIG(status), ::strsignal(WTERMSIG(status)));
  if (WIFEXITED(status)) return fmt::format("exited with status {}", WEXITSTATUS(status));
  return "stopped";
}

}  // namespace

int GmshWorkers::useful_count(int threads, std::size_t meshes) {
  const std::size_t n = std::min({static_cast<std::size_t>(std::max(threads, 1)), meshes,
                                  static_cast<std::size_t>(std::max(omp_get_num_procs(), 1))});
  return static_cast<int>(std::max<std::size_t>(n, 1));
}

GmshWorkers::GmshWorkers(int count) {
  if (count < 1) throw UsageError(fmt::format("GmshWorkers: at least one worker process is needed (got {})", count));
  workers_.resize(static_cast<std::size_t>(count));
  std::lock_guard lock(mutex_);
  try {
    for (std::size_t i = 0; i < workers_.size(); ++i) start(i);
  } catch (...) {
    std::vector<std::size_t> all(workers_.size());
    for (std::size_t i = 0; i < all.size(); ++i) all[i] = i;
    stop(all, true);  // those started so far: the destructor does not run for a failed constructor
    throw;
  }
}

GmshWorkers::~GmshWorkers() {
  std::lock_guard lock(mutex_);
  std::vector<std::size_t> all(workers_.size());
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = i;
  stop(all, false);
}

std::vector<pid_t> GmshWorkers::pids() const {
  std::lock_guard lock(mutex_);
  std::vector<pid_t> out;
  for (const Worker& w : workers_) out.push_back(w.pid);
  return out;
}

void GmshWorkers::start(std::size_t slot) {
  int ends[2];
  if (::socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, ends) != 0)
    throw DataError(fmt::format("could not start a gmsh worker process (socketpair: {}); raise the open-file limit", std::strerror(errno)));
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid < 0) {
    const int e = errno;
    ::close(ends[0]), ::close(ends[1]);
    throw DataError(fmt::format("could not start a gmsh worker process (fork: {}); run with fewer threads (-j)", std::strerror(e)));
  }
  if (pid == 0) {
    // Other workers' ends must close here, or they would not see end of stream when we close ours.
    for (const Worker& w : workers_)
      if (w.socket >= 0) ::close(w.socket);
    ::close(ends[0]);
    serve(ends[1], parent);
  }
  ::close(ends[1]);
  workers_[slot].pid = pid;
  workers_[slot].socket = ends[0];
}

void GmshWorkers::stop(const std::vector<std::size_t>& slots, bool kill) {
  for (std::size_t slot : slots) {
    Worker& w = workers_[slot];
    if (w.pid == 0) continue;
    if (kill || w.busy) ::kill(w.pid, SIGKILL);
    ::close(w.socket);  // an idle worker ends at end of stream
    w.socket = -1;
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(2);  // for a worker stuck in gmsh
  for (std::size_t slot : slots) {
    Worker& w = workers_[slot];
    if (w.pid == 0) continue;
    int status = 0;
    while (::waitpid(w.pid, &status, WNOHANG) == 0) {
      if (std::chrono::steady_clock::now() >= deadline) {
        ::kill(w.pid, SIGKILL);
        while (::waitpid(w.pid, &status, 0) < 0 && errno == EINTR) {
        }
        break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    w.pid = 0;
  }
}

TetMesh GmshWorkers::run(const detail::GmshRequest& request, TetReport& report, std::chrono::steady_clock::time_point deadline) {
  std::size_t slot = 0;
  {
    std::unique_lock lock(mutex_);
    freed_.wait(lock, [&] {
      for (slot = 0; slot < workers_.size(); ++slot)
        if (!workers_[slot].busy) return true;
      return false;
    });
    workers_[slot].busy = true;
    if (workers_[slot].pid == 0) start(slot);  // forked again after a crash
  }
  struct Release {
    GmshWorkers& pool;
    std::size_t slot;
    ~Release() {
      {
        std::lock_guard lock(pool.mutex_);
        pool.workers_[slot].busy = false;
      }
      pool.freed_.notify_one();
    }
  } release{*this, slot};
  const int fd = workers_[slot].socket;
  const pid_t pid = workers_[slot].pid;
  const auto started = std::chrono::steady_clock::now();
  const auto wait = [&] {  // until the reply can be read, or an interrupt, or the deadline
    for (pollfd p{fd, POLLIN, 0};;) {
      int timeout_ms = 100;
      if (deadline != std::chrono::steady_clock::time_point::max()) {
        const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now()).count();
        timeout_ms = static_cast<int>(std::clamp<long long>(left, 0, 100));
      }
      const int ready = ::poll(&p, 1, timeout_ms);
      if (ready > 0 || (ready < 0 && errno != EINTR)) return;  // recv reports errors
      if (interrupted()) {
        std::lock_guard lock(mutex_);
        stop({slot}, true);
        throw InterruptedError();
      }
      if (std::chrono::steady_clock::now() >= deadline) {
        std::lock_guard lock(mutex_);
        stop({slot}, true);  // killed and reaped; the next call forks a new one
        throw GmshOverrun(fmt::format("gmsh overran the time budget ({:.2f} s) and its worker was stopped",
                                      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count()));
      }
    }
  };
  std::vector<char> reply;
  if (!send_all(fd, encode_request(request)) || !receive_message(fd, reply, wait)) {
    // The worker died: reap it, say how, and let the next call fork a new one.
    int status = 0;
    ::kill(pid, SIGKILL);  // no effect on a dead one, whose status stays
    ::waitpid(pid, &status, 0);
    {
      std::lock_guard lock(mutex_);
      ::close(workers_[slot].socket);
      workers_[slot].pid = 0, workers_[slot].socket = -1;
    }
    throw DataError(fmt::format("the gmsh worker process {} {} while meshing {} (gmsh crashed on this input); a new worker "
                                "takes the next request",
                                pid, describe(status), request.body == detail::GmshRequest::Body::ellipsoid ? "an ellipsoid" : "a surface"));
  }
  try {
    return decode_reply(reply, report);
  } catch (const DataError&) {
    // A gmsh that failed is not to be trusted with the next request: after a PLC error in boundary
    // recovery, the same worker's next meshes (an ellipsoid, another grain) came out empty.
    std::lock_guard lock(mutex_);
    stop({slot}, true);
    throw;
  }
}

}  // namespace graintwin::mesh
