#include "graintwin/fdem/contact.hpp"

#include "graintwin/core/error.hpp"
#include "graintwin/io/h5file.hpp"

namespace graintwin::fdem {

// First commit of the contact API so the solver can code against it; the implementation follows.
struct ContactModel::State {};

namespace {
[[noreturn]] void not_implemented() { throw DataError("fdem contact is not implemented yet."); }
}  // namespace

ContactModel::ContactModel(const Model&, std::span<const double>, const ContactOptions&) {
  not_implemented();
}
ContactModel::~ContactModel() = default;
ContactModel::ContactModel(ContactModel&&) noexcept = default;
ContactModel& ContactModel::operator=(ContactModel&&) noexcept = default;

ContactStepStats ContactModel::add_forces(std::span<const Eigen::Vector3d>,
                                          std::span<const Eigen::Vector3d>,
                                          std::span<const PlatenState>, double,
                                          std::span<Eigen::Vector3d>) {
  not_implemented();
}
std::vector<ContactRecord> ContactModel::contacts() const { not_implemented(); }
double ContactModel::stable_time_step() const { not_implemented(); }
std::size_t ContactModel::rebuild_count() const { not_implemented(); }
double ContactModel::skin() const { not_implemented(); }
void ContactModel::save(io::H5File&, const std::string&) const { not_implemented(); }
void ContactModel::load(const io::H5File&, const std::string&) { not_implemented(); }

}  // namespace graintwin::fdem
