#pragma once
// The FDEM node contact law (docs/methods.md, FDEM), one node against one surface point or plane:
//   normal      F_n = max(0, k_n delta - 2 beta sqrt(m k_n) v_n),  k_n = p_n A
//   tangential  s <- R s - k_t v_t dt (R rotates the spring into the current tangent plane),
//               F_t = s - 2 beta sqrt(m k_t) v_t,  k_t = p_t A,  capped at mu F_n (slip).
// Units: m, m/s, kg, N, J, s.
#include <Eigen/Core>

namespace graintwin::fdem {

/// Spring and dashpot constants of one node contact.
struct ContactLaw {
  double normal_stiffness = 0;      ///< k_n, N/m
  double tangential_stiffness = 0;  ///< k_t, N/m
  double normal_damping = 0;        ///< 2 beta sqrt(m k_n), N s/m
  double tangential_damping = 0;    ///< 2 beta sqrt(m k_t), N s/m
  double friction = 0;              ///< Coulomb mu
};
/// k = p A, c = 2 beta sqrt(m k) for node mass m (kg), area A (m^2), penalties p (N/m^3).
ContactLaw contact_law(double normal_penalty, double tangential_penalty, double area, double mass,
                       double damping_ratio, double friction);

struct NodeContactForce {
  Eigen::Vector3d force = Eigen::Vector3d::Zero();   ///< on the node, N (the other side gets -force)
  double normal_force = 0;                           ///< F_n >= 0, N
  double normal_stiffness = 0;                       ///< N/m, k_n while the elastic overlap is positive, else 0
  Eigen::Vector3d spring = Eigen::Vector3d::Zero();  ///< tangential spring after the step, N (history)
  bool slipping = false;
  double elastic_energy = 0;  ///< J stored after the step: k_n delta^2 / 2 + |s|^2 / (2 k_t)
  double dissipated = 0;      ///< J lost in this step by the dashpots and by slip
};

/// Force on a node that penetrates by `overlap` (> 0) along `normal` (unit, the direction the
/// node is pushed), moving with `relative_velocity` (node minus surface), with the tangential
/// spring `spring` of the previous step (zero for a new contact).
NodeContactForce node_contact_force(const ContactLaw& law, const Eigen::Vector3d& normal, double overlap,
                                    const Eigen::Vector3d& relative_velocity, const Eigen::Vector3d& spring,
                                    double dt);

}  // namespace graintwin::fdem
