#include "graintwin/fdem/contact_law.hpp"

#include <algorithm>
#include <cmath>

namespace graintwin::fdem {

ContactLaw contact_law(double normal_penalty, double tangential_penalty, double area, double mass,
                       double damping_ratio, double friction) {
  ContactLaw law;
  law.normal_stiffness = normal_penalty * area;
  law.tangential_stiffness = tangential_penalty * area;
  law.normal_damping = 2 * damping_ratio * std::sqrt(mass * law.normal_stiffness);
  law.tangential_damping = 2 * damping_ratio * std::sqrt(mass * law.tangential_stiffness);
  law.friction = friction;
  return law;
}

NodeContactForce node_contact_force(const ContactLaw& law, const Eigen::Vector3d& normal, double overlap,
                                    const Eigen::Vector3d& relative_velocity, const Eigen::Vector3d& spring,
                                    double dt) {
  NodeContactForce out;
  const double separating = relative_velocity.dot(normal);
  const double elastic_normal = law.normal_stiffness * overlap;
  // The dashpot may not pull: clamp F_n at 0 while the contact opens fast.
  out.normal_force = std::max(0.0, elastic_normal - law.normal_damping * separating);
  out.dissipated = -(out.normal_force - elastic_normal) * separating * dt;
  out.normal_stiffness = overlap > 0 ? law.normal_stiffness : 0.0;

  const Eigen::Vector3d tangential_velocity = relative_velocity - separating * normal;
  // Rotate the stored spring into the current tangent plane, keeping its length.
  Eigen::Vector3d s = spring - spring.dot(normal) * normal;
  const double s_norm = s.norm(), spring_norm = spring.norm();
  if (s_norm > 0) s *= spring_norm / s_norm;
  s -= law.tangential_stiffness * dt * tangential_velocity;
  Eigen::Vector3d tangential = s - law.tangential_damping * tangential_velocity;
  const double cap = law.friction * out.normal_force;
  const double trial = tangential.norm();
  if (trial > cap) {
    out.slipping = true;
    tangential = trial > 0 ? Eigen::Vector3d(tangential * (cap / trial)) : Eigen::Vector3d::Zero();
    // The spring keeps at most the sliding force; what it loses is dissipated by slip.
    const double kept = std::min(s.norm(), cap);
    const double s_trial2 = s.squaredNorm();
    const Eigen::Vector3d s_kept = s.norm() > 0 ? Eigen::Vector3d(s * (kept / s.norm())) : Eigen::Vector3d::Zero();
    if (law.tangential_stiffness > 0) out.dissipated += (s_trial2 - s_kept.squaredNorm()) / (2 * law.tangential_stiffness);
    s = s_kept;
  }
  out.dissipated -= (tangential - s).dot(tangential_velocity) * dt;
  out.spring = s;
  out.force = out.normal_force * normal + tangential;
  out.elastic_energy = 0.5 * elastic_normal * overlap +
                       (law.tangential_stiffness > 0 ? s.squaredNorm() / (2 * law.tangential_stiffness) : 0.0);
  return out;
}

}  // namespace graintwin::fdem
