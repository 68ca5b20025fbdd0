#pragma once
// labels2contacts' stage (docs/labels2contacts.md): a segmented scan's labels (and its grey scan,
// when the normals are refined) in, the content of its contacts file out: the contacts found in
// the label image, their normals fitted to the grey levels, and the counts, fabric and roses of
// the counted ones.
#include <functional>
#include <string>
#include <vector>

#include "graintwin/contacts/contacts_file.hpp"
#include "graintwin/contacts/refine.hpp"
#include "graintwin/core/volume.hpp"
#include "graintwin/segment/labels_file.hpp"

namespace graintwin::contacts {

/// What scan_contacts gives: the file's content and, when refined, each contact's fit.
struct ScanContacts {
  ContactsFile content;
  std::vector<Refinement> fits;  ///< one per contact when settings.refined, else empty
};

/// The contacts of `labels` (a labels file's content, named `labels_name` in errors and warnings)
/// with `settings`; `grey` is the scan the labels were made from, needed when settings.refined
/// (UsageError otherwise). `progress` (may be empty) makes the progress callbacks of the steps
/// "contacts" and "refine normals". DataError when the grain table does not match the label image.
ScanContacts scan_contacts(const segment::LabelsFile& labels, const AnyVolume* grey, const ContactsSettings& settings,
                           const std::string& labels_name,
                           const std::function<std::function<void(double)>(const std::string&)>& progress = {});

}  // namespace graintwin::contacts
