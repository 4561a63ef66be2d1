// Signed requests (README "Security") in the Java client, byte-identical to the C++ client
// (services/security): a request_t inside a signed_request_t on <prefix>SREQUEST, signed with an
// Ed25519 key that `motionctl keygen` wrote. Ed25519 is the JDK's own (java.security, "Ed25519",
// JDK 15+); only the layout of the signed bytes is ours.
//
// The signature covers, concatenated (lcmtypes/signed_request_t.lcm):
//   "motionbus signed_request_t v1" NUL, channel prefix, NUL, key_id (8 bytes),
//   counter (int64 big-endian), utime (int64 big-endian), payload_size (int32 big-endian), payload.
//
// The coordinator's signed messages (signed_message_t, e.g. replies on SREPLY) cover
//   "motionbus signed_message_t v1" NUL, prefix, NUL, channel, NUL, key_id, counter, utime,
//   message_size, message (the same integers): messageSignedBytes; MessageVerifier checks them.
//
// Thread contract: Key and the static functions are thread-safe; RequestSigner.sign is synchronized.
import java.io.ByteArrayOutputStream;
import java.io.DataOutputStream;
import java.io.IOException;
import java.nio.ByteBuffer;
import java.nio.charset.StandardCharsets;
import java.nio.file.Files;
import java.nio.file.Path;
import java.nio.file.Paths;
import java.nio.file.attribute.PosixFilePermission;
import java.security.GeneralSecurityException;
import java.security.KeyFactory;
import java.security.KeyPair;
import java.security.KeyPairGenerator;
import java.security.PrivateKey;
import java.security.PublicKey;
import java.security.SecureRandom;
import java.security.Signature;
import java.security.spec.NamedParameterSpec;
import java.security.spec.PKCS8EncodedKeySpec;
import java.security.spec.X509EncodedKeySpec;
import java.util.Arrays;
import java.util.Base64;
import java.util.List;
import java.util.Set;

import motionlcm.request_t;
import motionlcm.signed_request_t;

public final class Signing {
    public static final String REQUEST_DOMAIN = "motionbus signed_request_t v1";
    public static final String MESSAGE_DOMAIN = "motionbus signed_message_t v1";
    public static final String PRIVATE_TAG = "motionbus-ed25519-private-key";
    public static final int KEY_ID_BYTES = 8;

    private Signing() {}

    /** A private key file that cannot be used (the message names the file, line and cause). */
    public static class KeyFileException extends Exception {
        private static final long serialVersionUID = 1L;
        public KeyFileException(String message) { super(message); }
    }

    // PKCS#8 of an Ed25519 private key (RFC 8410 §7) is this prefix and the 32-byte seed.
    private static final byte[] PKCS8_PREFIX = {0x30, 0x2e, 0x02, 0x01, 0x00, 0x30, 0x05, 0x06, 0x03, 0x2b, 0x65, 0x70, 0x04, 0x22, 0x04, 0x20};

    // X.509 SubjectPublicKeyInfo of an Ed25519 public key (RFC 8410 §4) is this prefix and the 32 bytes.
    private static final byte[] X509_PREFIX = {0x30, 0x2a, 0x30, 0x05, 0x06, 0x03, 0x2b, 0x65, 0x70, 0x03, 0x21, 0x00};

    // Hands the seed to the JDK's key pair generator, which takes the private key's 32 bytes from
    // its random source (the only way java.security derives the public key of a given seed).
    private static final class SeedRandom extends SecureRandom {
        private static final long serialVersionUID = 1L;
        private final byte[] seed;
        SeedRandom(byte[] seed) { this.seed = seed.clone(); }
        @Override public void nextBytes(byte[] bytes) { System.arraycopy(seed, 0, bytes, 0, Math.min(bytes.length, seed.length)); }
    }

    /** An Ed25519 key pair with its name (not final: a test may alter what sign() returns). */
    public static class Key {
        public final String name;
        private final PrivateKey privateKey;
        private final byte[] publicKey;

        protected Key(Key other) {
            name = other.name;
            privateKey = other.privateKey;
            publicKey = other.publicKey;
        }

        Key(byte[] seed, String name) throws GeneralSecurityException {
            if (seed.length != 32) throw new IllegalArgumentException("an Ed25519 seed has 32 bytes");
            this.name = name;
            byte[] der = Arrays.copyOf(PKCS8_PREFIX, PKCS8_PREFIX.length + 32);
            System.arraycopy(seed, 0, der, PKCS8_PREFIX.length, 32);
            privateKey = KeyFactory.getInstance("Ed25519").generatePrivate(new PKCS8EncodedKeySpec(der));
            KeyPairGenerator generator = KeyPairGenerator.getInstance("Ed25519");
            generator.initialize(NamedParameterSpec.ED25519, new SeedRandom(seed));
            KeyPair pair = generator.generateKeyPair();
            byte[] x509 = pair.getPublic().getEncoded();  // SubjectPublicKeyInfo: the raw key is its last 32 bytes
            publicKey = Arrays.copyOfRange(x509, x509.length - 32, x509.length);
        }

        public byte[] publicKey() { return publicKey.clone(); }
        public byte[] keyId() { return Arrays.copyOf(publicKey, KEY_ID_BYTES); }

        public byte[] sign(byte[] message) throws GeneralSecurityException {
            Signature s = Signature.getInstance("Ed25519");
            s.initSign(privateKey);
            s.update(message);
            return s.sign();
        }
    }

    public static Key fromSeed(byte[] seed, String name) throws GeneralSecurityException { return new Key(seed, name); }

    /** A principal's name: 1..64 of [A-Za-z0-9._-]. */
    public static boolean validName(String name) { return name.matches("[A-Za-z0-9._-]{1,64}"); }

    public static boolean nameOwnsClientId(String name, String clientId) { return clientId.equals(name) || clientId.startsWith(name + "/"); }

    /** The key file to sign with: the option's value, else $MOTION_KEY (as motionctl --key); null: unsigned. */
    public static String keyPath(String option) {
        if (option != null && !option.isEmpty()) return option;
        String env = System.getenv("MOTION_KEY");
        return env != null && !env.isEmpty() ? env : null;
    }

    /** Reads a private key file as motionctl keygen writes it; refuses one that group or others may
     *  access (as the C++ loader does), and any other content than one key line. */
    public static Key loadPrivateKey(String file) throws KeyFileException {
        Path path = Paths.get(file);
        List<String> lines;
        try {
            if (!Files.exists(path)) throw new KeyFileException("cannot read key file " + file + ": No such file or directory");
            if (!Files.isRegularFile(path)) throw new KeyFileException("key file " + file + " is not a regular file");
            Set<PosixFilePermission> perms = Files.getPosixFilePermissions(path);
            for (PosixFilePermission p : perms) {
                if (p.name().startsWith("GROUP") || p.name().startsWith("OTHERS")) {
                    boolean readable = perms.contains(PosixFilePermission.GROUP_READ) || perms.contains(PosixFilePermission.OTHERS_READ);
                    throw new KeyFileException("key file " + file + " is " + (readable ? "readable" : "accessible") + " by group/others (mode "
                                               + octal(perms) + "); chmod 600 it");
                }
            }
            lines = Files.readAllLines(path, StandardCharsets.UTF_8);
        } catch (IOException e) {
            throw new KeyFileException("cannot read key file " + file + ": " + e.getMessage());
        }
        Key found = null;
        for (int i = 0; i < lines.size(); i++) {
            String[] f = lines.get(i).trim().split("\\s+");
            if (f.length == 0 || f[0].isEmpty() || f[0].startsWith("#")) continue;
            String where = file + ":" + (i + 1) + ": ";
            if (found != null) throw new KeyFileException(where + "a second key line (a private key file holds one key)");
            if (f.length != 3 || !f[0].equals(PRIVATE_TAG)) {
                throw new KeyFileException(where + "expected '" + PRIVATE_TAG + " <base64 seed> <name>' (is this a private key file? a .pub file is not)");
            }
            byte[] seed;
            try {
                seed = Base64.getDecoder().decode(f[1]);
            } catch (IllegalArgumentException e) {
                seed = new byte[0];
            }
            if (seed.length != 32) throw new KeyFileException(where + "the seed is not base64 of 32 bytes");
            if (!validName(f[2])) throw new KeyFileException(where + "name '" + f[2] + "' is not 1..64 of [A-Za-z0-9._-]");
            try {
                found = new Key(seed, f[2]);
            } catch (GeneralSecurityException e) {
                throw new KeyFileException(where + "the JDK has no Ed25519 (JDK 15 or later needed): " + e.getMessage());
            }
        }
        if (found == null) throw new KeyFileException("key file " + file + " holds no key line");
        return found;
    }

    private static String octal(Set<PosixFilePermission> perms) {
        int mode = 0;
        for (PosixFilePermission p : perms) mode |= 1 << (8 - p.ordinal());  // OWNER_READ .. OTHERS_EXECUTE
        return String.format("%04o", mode);
    }

    /** What the signature covers (the layout is in lcmtypes/signed_request_t.lcm). */
    public static byte[] signedBytes(String prefix, byte[] keyId, long counter, long utime, byte[] payload) {
        return covered(REQUEST_DOMAIN, prefix, keyId, counter, utime, payload);
    }

    /** What the signature of a signed_message_t for `channel` covers (lcmtypes/signed_message_t.lcm). */
    public static byte[] messageSignedBytes(String prefix, String channel, byte[] keyId, long counter, long utime, byte[] message) {
        return covered(MESSAGE_DOMAIN, prefix + "\0" + channel, keyId, counter, utime, message);
    }

    // domain NUL scope NUL key_id counter utime size bytes (integers big-endian).
    private static byte[] covered(String domainText, String scope, byte[] keyId, long counter, long utime, byte[] payload) {
        byte[] domain = domainText.getBytes(StandardCharsets.UTF_8);
        byte[] pre = scope.getBytes(StandardCharsets.UTF_8);
        ByteBuffer b = ByteBuffer.allocate(domain.length + 1 + pre.length + 1 + KEY_ID_BYTES + 8 + 8 + 4 + payload.length);  // big-endian
        b.put(domain).put((byte) 0).put(pre).put((byte) 0).put(keyId, 0, KEY_ID_BYTES);
        b.putLong(counter).putLong(utime).putInt(payload.length).put(payload);
        return b.array();
    }

    /** The JDK's key of a raw 32-byte Ed25519 public key. */
    public static PublicKey publicKey(byte[] raw) throws GeneralSecurityException {
        if (raw.length != 32) throw new IllegalArgumentException("an Ed25519 public key has 32 bytes");
        byte[] der = Arrays.copyOf(X509_PREFIX, X509_PREFIX.length + 32);
        System.arraycopy(raw, 0, der, X509_PREFIX.length, 32);
        return KeyFactory.getInstance("Ed25519").generatePublic(new X509EncodedKeySpec(der));
    }

    /** The 32-byte key of a public key file ("<base64 public key> <name> [<role>]", as motionctl keygen
     *  writes <name>.pub), e.g. the coordinator's (security.coordinator_public_key). */
    public static byte[] loadPublicKey(String file) throws KeyFileException {
        List<String> lines;
        try {
            lines = Files.readAllLines(Paths.get(file), StandardCharsets.UTF_8);
        } catch (IOException e) {
            throw new KeyFileException("cannot read public key file " + file + ": " + e.getMessage());
        }
        for (int i = 0; i < lines.size(); i++) {
            String[] f = lines.get(i).trim().split("\\s+");
            if (f.length == 0 || f[0].isEmpty() || f[0].startsWith("#")) continue;
            byte[] key;
            try {
                key = Base64.getDecoder().decode(f[0]);
            } catch (IllegalArgumentException e) {
                key = new byte[0];
            }
            if (key.length != 32) throw new KeyFileException(file + ":" + (i + 1) + ": expected '<base64 public key> <name> [<role>]' (is this a .pub file?)");
            return key;
        }
        throw new KeyFileException("public key file " + file + " holds no key line");
    }

    /** A request_t as LCM encodes it (with its fingerprint). */
    public static byte[] encode(request_t request) {
        try {
            ByteArrayOutputStream bytes = new ByteArrayOutputStream();
            request.encode(new DataOutputStream(bytes));
            return bytes.toByteArray();
        } catch (IOException e) {
            throw new IllegalStateException("encoding into memory failed", e);
        }
    }

    /** Signs a client's requests with one key for the channel prefix they go out on. */
    public static final class RequestSigner {
        public final Key key;
        private final String prefix;
        private long lastCounter = 0;

        public RequestSigner(Key key, String prefix) {
            this.key = key;
            this.prefix = prefix;
        }

        /** clientId unchanged when it is the key's name or "<name>/...", else "<name>/<clientId>". */
        public String ownClientId(String clientId) { return nameOwnsClientId(key.name, clientId) ? clientId : key.name + "/" + clientId; }

        /** The signed_request_t of `request`, signed at nowUs (µs since the epoch) with the next counter, max(last + 1, nowUs). */
        public synchronized signed_request_t sign(request_t request, long nowUs) throws GeneralSecurityException {
            signed_request_t e = new signed_request_t();
            e.utime = nowUs;
            e.key_id = key.keyId();
            lastCounter = Math.max(lastCounter + 1, nowUs);
            e.counter = lastCounter;
            e.payload = encode(request);
            e.payload_size = e.payload.length;
            e.signature = key.sign(signedBytes(prefix, e.key_id, e.counter, e.utime, e.payload));
            return e;
        }
    }
}
