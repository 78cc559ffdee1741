/* Preloaded into every test of a sanitizer build (tests/CMakeLists.txt): dlclose does nothing, so
 * shared libraries stay mapped until the process exits.
 *
 * Why: the Vulkan loader unloads the ICD (Mesa's lavapipe, with LLVM) and the validation layer when
 * the instance is destroyed. Memory that those libraries keep for the life of the process, reachable
 * only from their own globals, then looks leaked to LeakSanitizer, which no longer scans the
 * unloaded data segments, and its stack shows only "<unknown module>", which no suppression can
 * match. With the libraries kept, LeakSanitizer sees those globals, and the suppressions in
 * lsan.supp name the modules of what remains. Leaks in shrefract's own code are still reported. */
int dlclose(void* handle) {
  (void)handle;
  return 0;
}
