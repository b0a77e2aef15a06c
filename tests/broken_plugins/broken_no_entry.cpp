// Broken on purpose: a shared object without the entry point `locd_plugin_descriptor`.
extern "C" __attribute__((visibility("default"))) int locd_broken_no_entry_marker() { return 42; }
