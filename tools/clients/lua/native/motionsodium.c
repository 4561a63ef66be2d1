/* motionsodium: the native part of the Lua client's signing (motionsigning.lua), a Lua 5.2 module
 * over libsodium, the library the C++ code signs with. Debian's Lua OpenSSL binding
 * (lua-luaossl 20220711) cannot make Ed25519 signatures: its pkey:sign goes through
 * EVP_SignFinal, which OpenSSL 3 refuses for Ed25519 ("operation not supported for this keytype";
 * Ed25519 needs the one-shot EVP_DigestSign, which luaossl does not bind). So this module binds
 * the few calls needed, and no cryptography is written here:
 *   public_key(seed)          32-byte Ed25519 public key of a 32-byte seed
 *   sign(seed, message)       64-byte Ed25519 signature (crypto_sign_detached)
 *   verify(public, message, signature)   boolean
 *   base64_decode(text)       bytes, or nil when text is not standard base64 with padding
 *   file_mode(path)           st_mode of stat(2) and whether it is a regular file, or nil, error
 *   now_us()                  the wall clock in µs since the epoch (Lua 5.2 has only whole seconds;
 *                             a signed request's utime and counter need better)
 *   monotonic()               seconds (with a fraction) of CLOCK_MONOTONIC: the Lua client's
 *                             timeouts and its sending again after 0.5 s of silence need better
 *                             than os.time()'s whole seconds, and no steps of the wall clock
 * Strings are Lua byte strings. Thread contract: no state; each call is independent. */
#include <errno.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>

#include <lauxlib.h>
#include <lua.h>
#include <sodium.h>

static const unsigned char *check_bytes(lua_State *L, int arg, size_t size, const char *what) {
  size_t n = 0;
  const char *s = luaL_checklstring(L, arg, &n);
  if (n != size) luaL_error(L, "%s must be %d bytes, not %d", what, (int)size, (int)n);
  return (const unsigned char *)s;
}

static int l_public_key(lua_State *L) {
  const unsigned char *seed = check_bytes(L, 1, crypto_sign_SEEDBYTES, "the seed");
  unsigned char pk[crypto_sign_PUBLICKEYBYTES];
  unsigned char sk[crypto_sign_SECRETKEYBYTES];
  crypto_sign_seed_keypair(pk, sk, seed);
  sodium_memzero(sk, sizeof sk);
  lua_pushlstring(L, (const char *)pk, sizeof pk);
  return 1;
}

static int l_sign(lua_State *L) {
  const unsigned char *seed = check_bytes(L, 1, crypto_sign_SEEDBYTES, "the seed");
  size_t n = 0;
  const unsigned char *message = (const unsigned char *)luaL_checklstring(L, 2, &n);
  unsigned char pk[crypto_sign_PUBLICKEYBYTES];
  unsigned char sk[crypto_sign_SECRETKEYBYTES];
  unsigned char sig[crypto_sign_BYTES];
  crypto_sign_seed_keypair(pk, sk, seed);
  crypto_sign_detached(sig, NULL, message, n, sk);
  sodium_memzero(sk, sizeof sk);
  lua_pushlstring(L, (const char *)sig, sizeof sig);
  return 1;
}

static int l_verify(lua_State *L) {
  const unsigned char *pk = check_bytes(L, 1, crypto_sign_PUBLICKEYBYTES, "the public key");
  size_t n = 0;
  const unsigned char *message = (const unsigned char *)luaL_checklstring(L, 2, &n);
  const unsigned char *sig = check_bytes(L, 3, crypto_sign_BYTES, "the signature");
  lua_pushboolean(L, crypto_sign_verify_detached(sig, message, n, pk) == 0);
  return 1;
}

static int l_base64_decode(lua_State *L) {
  size_t n = 0;
  const char *text = luaL_checklstring(L, 1, &n);
  luaL_Buffer b;
  const size_t room = n / 4 * 3 + 3;
  unsigned char *out = (unsigned char *)luaL_buffinitsize(L, &b, room);
  size_t length = 0;
  const char *end = NULL;
  if (sodium_base642bin(out, room, text, n, NULL, &length, &end, sodium_base64_VARIANT_ORIGINAL) != 0 || end != text + n) {
    lua_pushnil(L);
    return 1;
  }
  luaL_pushresultsize(&b, length);
  return 1;
}

static int l_file_mode(lua_State *L) {
  const char *path = luaL_checkstring(L, 1);
  struct stat st;
  if (stat(path, &st) != 0) {
    lua_pushnil(L);
    lua_pushstring(L, strerror(errno));
    return 2;
  }
  lua_pushinteger(L, (lua_Integer)(st.st_mode & 07777));
  lua_pushboolean(L, S_ISREG(st.st_mode));
  return 2;
}

static int l_now_us(lua_State *L) {
  struct timespec ts;
  clock_gettime(CLOCK_REALTIME, &ts);
  /* About 2^51 today: exact in a Lua 5.2 number (a double). */
  const long long us = (long long)ts.tv_sec * 1000000LL + ts.tv_nsec / 1000; /* whole microseconds */
  lua_pushnumber(L, (lua_Number)us);
  return 1;
}

static int l_monotonic(lua_State *L) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  lua_pushnumber(L, (lua_Number)ts.tv_sec + (lua_Number)ts.tv_nsec / 1e9);
  return 1;
}

static const luaL_Reg kFunctions[] = {
    {"public_key", l_public_key}, {"sign", l_sign}, {"verify", l_verify},
    {"base64_decode", l_base64_decode}, {"file_mode", l_file_mode}, {"now_us", l_now_us},
    {"monotonic", l_monotonic},
    {NULL, NULL},
};

int luaopen_motionsodium(lua_State *L);
int luaopen_motionsodium(lua_State *L) {
  if (sodium_init() < 0) return luaL_error(L, "libsodium cannot start (no entropy source)");
  luaL_newlib(L, kFunctions);
  return 1;
}
