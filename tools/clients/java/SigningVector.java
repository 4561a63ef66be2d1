// Signing in the Java client against the cross-language vector (tests/vectors/signed_request_v1.txt,
// the bytes the C++ code produces): key file, payload, signed bytes, signature and the encoded
// signed_request_t; the key file rules (mode 0600). Exit 0 when every check passes, else 1 naming
// the ones that failed (ctest clients_java_signing).
//   java -cp lcm.jar:motionlcm.jar:classes SigningVector tests/vectors/signed_request_v1.txt
import java.io.ByteArrayOutputStream;
import java.io.DataOutputStream;
import java.nio.charset.StandardCharsets;
import java.nio.file.Files;
import java.nio.file.Path;
import java.nio.file.attribute.PosixFilePermissions;
import java.util.HashMap;
import java.util.Map;

import motionlcm.param_t;
import motionlcm.request_t;
import motionlcm.signed_request_t;

public class SigningVector {
    static int failures = 0;

    static void check(String what, Object actual, Object expected) {
        boolean ok = String.valueOf(actual).equals(String.valueOf(expected));
        System.out.println((ok ? "ok   " : "FAIL ") + what + (ok ? "" : ": got " + actual + ", expected " + expected));
        if (!ok) failures++;
    }

    static String hex(byte[] bytes) {
        StringBuilder b = new StringBuilder();
        for (byte x : bytes) b.append(String.format("%02x", x & 0xff));
        return b.toString();
    }

    public static void main(String[] argv) throws Exception {
        Map<String, String> v = new HashMap<>();
        for (String line : Files.readAllLines(Path.of(argv[0]), StandardCharsets.UTF_8)) {
            int eq = line.indexOf(" = ");
            if (!line.startsWith("#") && eq > 0) v.put(line.substring(0, eq), line.substring(eq + 3));
        }
        Path dir = Files.createTempDirectory("motion-java-vector");
        Path keyFile = dir.resolve("vector.key");
        try {
            Files.writeString(keyFile, "# the vector's key\n" + v.get("key_file_line") + "\n");
            Files.setPosixFilePermissions(keyFile, PosixFilePermissions.fromString("rw-------"));
            Signing.Key key = Signing.loadPrivateKey(keyFile.toString());
            check("key name", key.name, v.get("key_name"));
            check("public key", hex(key.publicKey()), v.get("public_key_hex"));
            check("key id", hex(key.keyId()), v.get("key_id_hex"));

            request_t r = MotionClient.make(Byte.parseByte(v.get("request.kind")), v.get("request.axes").split(" "), null);
            String[] values = v.get("request.values").split(" ");
            for (int i = 0; i < values.length; i++) r.values[i] = Double.parseDouble(values[i]);
            r.utime = Long.parseLong(v.get("request.utime"));
            r.client_id = v.get("request.client_id");
            r.request_id = Long.parseLong(v.get("request.request_id"));
            r.velocity_scale = Double.parseDouble(v.get("request.velocity_scale"));
            r.acceleration_scale = Double.parseDouble(v.get("request.acceleration_scale"));
            r.timeout_ms = Integer.parseInt(v.get("request.timeout_ms"));
            r.output_mask = Integer.parseInt(v.get("request.output_mask"));
            r.output_value = Integer.parseInt(v.get("request.output_value"));
            r.param = new param_t();
            r.param.mnemonic = "";

            Signing.RequestSigner signer = new Signing.RequestSigner(key, v.get("prefix"));
            signed_request_t e = signer.sign(r, Long.parseLong(v.get("utime")));
            check("counter", e.counter, v.get("counter"));
            check("payload", hex(e.payload), v.get("payload_hex"));
            check("signed bytes", hex(Signing.signedBytes(v.get("prefix"), e.key_id, e.counter, e.utime, e.payload)), v.get("signed_bytes_hex"));
            check("signature", hex(e.signature), v.get("signature_hex"));
            ByteArrayOutputStream out = new ByteArrayOutputStream();
            e.encode(new DataOutputStream(out));
            check("envelope", hex(out.toByteArray()), v.get("envelope_hex"));
            check("next counter", signer.sign(r, Long.parseLong(v.get("utime"))).counter, Long.parseLong(v.get("counter")) + 1);
            check("own client id", signer.ownClientId("tool"), "vector/tool");

            Files.setPosixFilePermissions(keyFile, PosixFilePermissions.fromString("rw-r--r--"));
            String refused = "";
            try {
                Signing.loadPrivateKey(keyFile.toString());
            } catch (Signing.KeyFileException ex) {
                refused = ex.getMessage();
            }
            check("mode 0644 refused", refused.endsWith("is readable by group/others (mode 0644); chmod 600 it"), true);
        } finally {
            Files.deleteIfExists(keyFile);
            Files.deleteIfExists(dir);
        }
        System.out.println(failures == 0 ? "signing vector ok" : failures + " check(s) failed");
        System.exit(failures == 0 ? 0 : 1);
    }
}
