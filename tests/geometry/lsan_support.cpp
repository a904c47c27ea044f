// LeakSanitizer suppression for the geometry tests in sanitizer builds: Debian's assimp 5.2.5 leaks
// memory inside libassimp when one of its importers gives up on a malformed file (the mutation test
// makes it do so hundreds of times). Nothing of ours is suppressed.
extern "C" const char* __lsan_default_suppressions() { return "leak:libassimp.so\n"; }
