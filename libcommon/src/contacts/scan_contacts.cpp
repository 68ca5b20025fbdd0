#include "graintwin/contacts/scan_contacts.hpp"

#include <spdlog/spdlog.h>

#include <variant>

#include "graintwin/contacts/detect.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/core/interrupt.hpp"

namespace graintwin::contacts {

ScanContacts scan_contacts(const segment::LabelsFile& labels, const AnyVolume* grey, const ContactsSettings& settings,
                           const std::string& labels_name,
                           const std::function<std::function<void(double)>(const std::string&)>& progress) {
  if (settings.refined && grey == nullptr)
    throw UsageError("refined contact normals need the grey scan the labels of " + labels_name + " were made from");
  const auto step = [&](const char* name) { return progress ? progress(name) : std::function<void(double)>(); };
  std::vector<Contact> found;
  try {
    found = find_contacts(labels.labels, labels.grains, {settings.min_voxels}, step("contacts"));
  } catch (Error& e) {
    e.add_context("in " + labels_name + "; its grain table does not match its label image");
    throw;  // as itself: `throw e` would throw a copy of the base class
  }
  throw_if_interrupted();
  if (found.empty()) spdlog::warn("no contacts: the grains of {} do not touch", labels_name);

  ScanContacts out;
  if (settings.refined) {
    RefineParams rp;
    rp.window_vox = settings.window_vox;
    rp.gap_tolerance_vox = settings.gap_tolerance_vox;
    std::visit([&](const auto& g) { out.fits = refine_contacts(g, labels.labels, found, labels.grains, rp, step("refine normals")); },
               *grey);
    throw_if_interrupted();
  }
  out.content = contacts_content(found, out.fits, labels.grains, settings);
  return out;
}

}  // namespace graintwin::contacts
