// The gateways' keys of an authorized_keys file (README "Security"), as the C++
// security::AuthorizedKeys reads the file: one principal per line, "<base64 public key> <name>
// <role> [buses=<bus>,...]", blank lines and # comments ignored; every bad line is named
// ("file:line: what was wrong"). Only the lines of role `gateway` are kept: the keys gateways sign
// their axis states with (MotionClient.verifyStatesWith). A line's buses= binds its key to those
// buses: it vouches only for states of an axis on one of them; without it, for every bus.
//
// Thread contract: immutable values; the static functions are pure.
import java.io.IOException;
import java.nio.charset.StandardCharsets;
import java.nio.file.Files;
import java.nio.file.Paths;
import java.util.ArrayList;
import java.util.Arrays;
import java.util.Base64;
import java.util.HashMap;
import java.util.List;
import java.util.Map;

public final class GatewayKeys {
    public static final List<String> ROLES = List.of("observe", "operate", "configure", "admin", "gateway");
    public static final String BUSES_TOKEN = "buses=";

    private GatewayKeys() {}

    /** A key of role gateway: its 32 bytes, name, and the buses it may vouch for (null: every bus). */
    public static final class Key {
        public final byte[] publicKey;
        public final String name;
        public final List<String> buses;

        public Key(byte[] publicKey, String name, List<String> buses) {
            this.publicKey = publicKey.clone();
            this.name = name;
            this.buses = buses == null ? null : List.copyOf(buses);
        }

        public byte[] keyId() { return Arrays.copyOf(publicKey, Signing.KEY_ID_BYTES); }

        public boolean vouchesFor(String bus) { return buses == null || buses.contains(bus); }
    }

    /** The gateway keys of `text` (an authorized_keys file's content; fileName names it in errors). */
    public static List<Key> parse(String text, String fileName) throws Signing.KeyFileException {
        List<Key> out = new ArrayList<>();
        List<String> errors = new ArrayList<>();
        Map<String, Integer> keyLines = new HashMap<>();
        Map<String, Integer> nameLines = new HashMap<>();
        String[] lines = text.split("\n", -1);
        for (int i = 0; i < lines.length; i++) {
            String[] f = lines[i].trim().split("\\s+");
            if (f.length == 0 || f[0].isEmpty() || f[0].startsWith("#")) continue;
            String where = fileName + ":" + (i + 1) + ": ";
            if (f.length != 3 && f.length != 4) {
                errors.add(where + "expected '<base64 public key> <name> <role> [" + BUSES_TOKEN + "<bus>,...]', got " + f.length + " field" + (f.length == 1 ? "" : "s"));
                continue;
            }
            byte[] key;
            try {
                key = Base64.getDecoder().decode(f[0]);
            } catch (IllegalArgumentException e) {
                key = new byte[0];
            }
            if (key.length != 32) {
                errors.add(where + "'" + f[0].substring(0, Math.min(16, f[0].length())) + (f[0].length() > 16 ? "...'" : "'") + " is not a base64 Ed25519 public key (32 bytes)");
                continue;
            }
            String name = f[1];
            String role = f[2];
            if (!Signing.validName(name)) {
                errors.add(where + "name '" + name + "' is not 1..64 of [A-Za-z0-9._-]");
                continue;
            }
            if (!ROLES.contains(role)) {
                errors.add(where + "unknown role '" + role + "' (" + String.join(", ", ROLES) + ")");
                continue;
            }
            List<String> buses = null;
            if (f.length == 4) {
                buses = Arrays.asList(f[3].substring(Math.min(BUSES_TOKEN.length(), f[3].length())).split(",", -1));
                if (!f[3].startsWith(BUSES_TOKEN) || buses.contains("")) {
                    errors.add(where + "expected '" + BUSES_TOKEN + "<bus>[,<bus>...]' after the role, got '" + f[3].substring(0, Math.min(64, f[3].length())) + "'");
                    continue;
                }
                if (!role.equals("gateway")) {
                    errors.add(where + BUSES_TOKEN + " binds a key of role gateway to buses; '" + name + "' has role " + role);
                    continue;
                }
            }
            String id = MessageVerifier.hex(Arrays.copyOf(key, Signing.KEY_ID_BYTES));  // key ids are 8 bytes of the key
            if (keyLines.containsKey(id)) {
                errors.add(where + "key of '" + name + "' is already listed at line " + keyLines.get(id) + " (same key id " + id + ")");
                continue;
            }
            if (nameLines.containsKey(name)) {
                errors.add(where + "name '" + name + "' is already used at line " + nameLines.get(name));
                continue;
            }
            keyLines.put(id, i + 1);
            nameLines.put(name, i + 1);
            if (role.equals("gateway")) out.add(new Key(key, name, buses));
        }
        if (!errors.isEmpty()) throw new Signing.KeyFileException(String.join("\n", errors));
        return out;
    }

    /** The gateway keys of an authorized_keys file (security.authorized_keys); refuses a file without any. */
    public static List<Key> load(String file) throws Signing.KeyFileException {
        String text;
        try {
            text = Files.readString(Paths.get(file), StandardCharsets.UTF_8);
        } catch (IOException e) {
            throw new Signing.KeyFileException("cannot read authorized keys file " + file + ": " + e.getMessage());
        }
        List<Key> keys = parse(text, file);
        if (keys.isEmpty()) throw new Signing.KeyFileException("authorized keys file " + file + " has no key of role gateway");
        return keys;
    }
}
