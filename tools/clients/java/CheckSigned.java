// Checks signing in the Java client against a coordinator with `security: {mode: enforce}` (used by
// ctest test_clients): a signed enable and move of one axis, then the same move unsigned, signed
// with a key the coordinator does not know, and with the right key but its signature altered
// (forged); one line each, as check_signed.py prints them:
//   signed: status=done ...   x = 12.5   unsigned: status=rejected error_code=19 ...
//   stranger: status=rejected error_code=19 ...   forged: status=rejected error_code=19 ...
//   after: x = 12.5
// With --coordinator-key (the coordinator's .pub file) every client verifies the coordinator's
// replies and SECURITY events (verifyWith): the signed move's DONE is then the coordinator's signed
// reply, and the refusals come from its signed SECURITY events. The "after" line (the axis's
// position from its axis state) ends in "(unverified)", or with --gateway-keys (an authorized_keys
// file) in "(signed by a gateway, N refused)": the client then takes only axis states signed by
// one of its keys of role gateway (verifyStatesWith).
// Exit 0 when all came as expected, 1 otherwise, 2 bad command line or key file, 4 LCM unavailable.
//   java -cp lcm.jar:motionlcm.jar:classes CheckSigned --lcm-url URL [--prefix MOTION_] [--key FILE]
//        --stranger-key FILE --axis x --target 12.5 [--coordinator-key FILE] [--gateway-keys FILE]
//        (--key defaults to $MOTION_KEY)
import java.io.IOException;
import java.security.GeneralSecurityException;
import java.util.Map;

import motionlcm.axis_state_t;
import motionlcm.reply_t;
import motionlcm.request_t;

public class CheckSigned {
    static final String USAGE = "usage: CheckSigned --lcm-url URL [--prefix MOTION_] [--key FILE] --stranger-key FILE --axis A --target P [--coordinator-key FILE] [--gateway-keys FILE]";

    /** `key` whose signatures have one bit flipped: what an attacker altering a message gets. */
    static final class ForgedKey extends Signing.Key {
        ForgedKey(Signing.Key key) { super(key); }

        @Override
        public byte[] sign(byte[] message) throws GeneralSecurityException {
            byte[] s = super.sign(message);
            s[5] ^= 0x10;
            return s;
        }
    }

    static String line(String name, reply_t r) {
        return name + ": status=" + MotionClient.statusName(r.status) + " error_code=" + r.error_code + " reason=" + r.reason;
    }

    public static void main(String[] argv) throws Exception {
        Args args = new Args(argv, Map.of("--lcm-url", 1, "--prefix", 1, "--key", 1, "--stranger-key", 1, "--axis", 1, "--target", 1, "--coordinator-key", 1, "--gateway-keys", 1), USAGE);
        String axis = args.get("--axis", "x");
        double target;
        try {
            target = Double.parseDouble(args.get("--target", ""));
        } catch (NumberFormatException e) {
            Args.fail("--target: not a number", USAGE);
            return;
        }
        String keyPath = Signing.keyPath(args.get("--key", null));
        if (keyPath == null) Args.fail("no key: --key FILE or $MOTION_KEY", USAGE);
        Signing.Key key;
        Signing.Key stranger;
        byte[] coordinator = null;
        java.util.List<GatewayKeys.Key> gateways = null;
        try {
            key = Signing.loadPrivateKey(keyPath);
            stranger = Signing.loadPrivateKey(args.get("--stranger-key", ""));
            String coordinatorKey = args.get("--coordinator-key", null);
            if (coordinatorKey != null) coordinator = Signing.loadPublicKey(coordinatorKey);
            String gatewayKeys = args.get("--gateway-keys", null);
            if (gatewayKeys != null) gateways = GatewayKeys.load(gatewayKeys);
        } catch (Signing.KeyFileException e) {
            System.err.println("CheckSigned: " + e.getMessage());
            System.exit(2);
            return;
        }
        String url = args.get("--lcm-url", null);
        String prefix = args.get("--prefix", "MOTION_");
        boolean ok;
        try (MotionClient signed = new MotionClient(url, prefix, "CheckSigned.java");
             MotionClient plain = new MotionClient(url, prefix, "CheckSigned.java-plain");
             MotionClient other = new MotionClient(url, prefix, "CheckSigned.java");
             MotionClient forger = new MotionClient(url, prefix, "CheckSigned.java-forged")) {
            signed.signWith(key);
            other.signWith(stranger);
            forger.signWith(new ForgedKey(key));
            if (coordinator != null) {
                for (MotionClient c : new MotionClient[] {signed, plain, other, forger}) c.verifyWith(coordinator);
                System.out.println("verifying the coordinator's replies");
            }
            if (gateways != null) signed.verifyStatesWith(gateways, 2000);
            reply_t r = signed.request(request_t.ENABLE, new String[] {axis}, null, 10000);
            if (r.status == reply_t.DONE) r = signed.request(request_t.MOVE_ABSOLUTE, new String[] {axis}, new double[] {target}, 20000);
            System.out.println(line("signed", r));
            ok = r.status == reply_t.DONE;
            if (ok) {
                for (int i = 0; i < r.num_axes; i++) if (r.axes[i].equals(axis)) System.out.printf("%s = %.6g%n", axis, r.positions[i]);
            }
            for (Object[] c : new Object[][] {{"unsigned", plain}, {"stranger", other}, {"forged", forger}}) {
                r = ((MotionClient) c[1]).request(request_t.MOVE_ABSOLUTE, new String[] {axis}, new double[] {target + 5.0}, 5000);
                System.out.println(line((String) c[0], r));
                ok &= r.status == reply_t.REJECTED && r.error_code == MotionClient.UNAUTHORIZED;
            }
            Thread.sleep(500);  // a move that had been executed would have the axis on its way by now
            axis_state_t s = signed.axisStates().get(axis);
            String verified = signed.statesVerified() ? "(signed by a gateway, " + signed.forgedStates() + " refused)" : "(unverified)";
            System.out.println(s != null ? String.format("after: %s = %.6g %s", axis, s.position, verified) : "after: no state of " + axis);
        } catch (IOException e) {
            System.err.println("CheckSigned: LCM unavailable: " + e.getMessage());
            System.exit(4);
            return;
        }
        System.out.flush();
        System.exit(ok ? 0 : 1);
    }
}
