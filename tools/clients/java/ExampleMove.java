// Enables two axes, moves them together (one synchronized request) and prints their final positions.
//   java -cp lcm.jar:motionlcm.jar:classes ExampleMove [--lcm-url URL] [--prefix MOTION_] [--axes x y]
//        [--targets 10 5] [--timeout 60] [--key FILE]
// --key (default $MOTION_KEY): sign the requests with this private key (motionctl keygen).
// Exit codes: 0 done, 1 the coordinator refused or the move failed (its reason is printed),
// 2 bad command line, 4 LCM unavailable.
import java.io.IOException;
import java.util.Arrays;
import java.util.LinkedHashMap;
import java.util.List;
import java.util.Map;

import motionlcm.reply_t;

public class ExampleMove {
    static final String USAGE = "usage: ExampleMove [--lcm-url URL] [--prefix MOTION_] [--axes A B] [--targets P Q] [--timeout S] [--key FILE]";

    public static void main(String[] argv) throws Exception {
        Map<String, Integer> arity = Map.of("--lcm-url", 1, "--prefix", 1, "--axes", 2, "--targets", 2, "--timeout", 1, "--key", 1);
        Args args = new Args(argv, arity, USAGE);
        List<String> axes = args.list("--axes", Arrays.asList("x", "y"));
        List<String> targets = args.list("--targets", Arrays.asList("10", "5"));
        long timeoutMs;
        Map<String, Double> move = new LinkedHashMap<>();
        try {
            timeoutMs = (long) (Double.parseDouble(args.get("--timeout", String.valueOf(MotionClient.REQUEST_TIMEOUT_MS / 1000.0))) * 1000);
            for (int i = 0; i < 2; i++) move.put(axes.get(i), Double.parseDouble(targets.get(i)));
        } catch (NumberFormatException e) {
            Args.fail("not a number: " + e.getMessage(), USAGE);
            return;
        }
        MotionClient client;
        try {
            client = new MotionClient(args.get("--lcm-url", null), args.get("--prefix", "MOTION_"), "ExampleMove.java");
        } catch (IOException e) {
            System.err.println("ExampleMove: LCM unavailable: " + e.getMessage());
            System.exit(4);
            return;
        }
        String keyPath = Signing.keyPath(args.get("--key", null));
        if (keyPath != null) {
            try {
                client.signWith(Signing.loadPrivateKey(keyPath));
            } catch (Signing.KeyFileException e) {
                System.err.println("ExampleMove: --key: " + e.getMessage());
                client.close();
                System.exit(2);
                return;
            }
        }
        int rc = 0;
        try (MotionClient c = client) {
            c.requestOrThrow(MotionClient.make(motionlcm.request_t.ENABLE, axes.toArray(new String[0]), null), timeoutMs, null);
            System.out.println("enabled " + String.join(" ", axes));
            reply_t done = c.move(move, false, timeoutMs, r -> System.out.printf("  %s %5.1f%%%n", MotionClient.statusName(r.status), r.progress * 100));
            if (done.status != reply_t.DONE) throw new MotionClient.RequestFailed(done);
            for (String axis : axes) {
                double pos = Double.NaN;
                for (int i = 0; i < done.num_axes; i++) if (done.axes[i].equals(axis)) pos = done.positions[i];
                System.out.printf("%s = %.6g%n", axis, pos);
            }
            System.out.printf("measured start skew %.1f us (predicted arrival spread %.1f us)%n", done.measured_start_skew_us, done.predicted_skew_us);
        } catch (MotionClient.RequestFailed e) {
            System.err.println("ExampleMove: " + e.getMessage());
            rc = 1;
        }
        System.exit(rc);
    }
}
