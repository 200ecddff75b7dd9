// mocapd's jemalloc options, read by jemalloc at its first allocation (MALLOC_CONF in the
// environment still overrides them).
//
// A recording's threads allocate and free tens of MB and then end. jemalloc returns freed pages
// only as its arenas are used, so an arena left idle by them would keep its pages: a background
// thread purges them instead, and after a second rather than jemalloc's ten, so that between
// recordings the daemon holds what it uses.
extern "C" {
const char* malloc_conf = "background_thread:true,dirty_decay_ms:1000,muzzy_decay_ms:0";
}
