#pragma once
// SIGINT and SIGTERM as a flag that long loops poll, and the commit point after which a run no
// longer listens to them (docs/conventions.md, "Outputs"): a signal either leaves no output and
// says so, or arrives once the outputs are being put in place and is ignored.

namespace graintwin {

/// Installs the SIGINT/SIGTERM handlers that set the flag (a second signal before the commit
/// point ends the process the usual way; its temporaries are cleared by the next run).
void install_interrupt_handlers();
/// True once SIGINT or SIGTERM arrived before the commit point.
bool interrupted();
/// Throws InterruptedError if interrupted(); call it at safe points outside parallel regions.
void throw_if_interrupted();

/// The commit point: from here on SIGINT and SIGTERM are ignored, so the outputs are put in place
/// whole. Throws InterruptedError (and keeps listening) when a signal arrived before it.
void pass_commit_point();
/// True once pass_commit_point() succeeded in this process.
bool commit_point_passed();

}  // namespace graintwin
