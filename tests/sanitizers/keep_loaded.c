/* Preloaded into every process of the sanitizer suite (scripts/run-sanitizers.sh): dlclose() does
 * nothing, so shared libraries stay loaded until the process exits. Mesa unloads its GL driver
 * in eglTerminate(); LeakSanitizer runs after that, and then (measured on `glint render` under
 * LSan, 2026-12-03) the blocks the driver still pointed to from its own globals show as leaks
 * "allocated from <unknown module>": the roots are gone and the frames cannot be named, so no
 * suppression can match them. With the driver kept loaded its globals stay roots and that run
 * reports nothing. */
int dlclose(void* handle) {
    (void)handle;
    return 0;
}
