// Checks the Java client against a running motion-coordinator (used by ctest test_clients): hears its
// heartbeat, sends a request for an unknown axis and one with a non-finite value, prints one line
// per check (same format as check_coordinator.py) and exits 0 when all came as expected, else 1.
//   java -cp lcm.jar:motionlcm.jar:classes CheckCoordinator --lcm-url URL [--prefix MOTION_] [--axis x]
import java.io.IOException;
import java.util.Map;

import motionlcm.health_t;
import motionlcm.reply_t;
import motionlcm.request_t;

public class CheckCoordinator {
    public static void main(String[] argv) throws Exception {
        Args args = new Args(argv, Map.of("--lcm-url", 1, "--prefix", 1, "--axis", 1),
                             "usage: CheckCoordinator --lcm-url URL [--prefix MOTION_] [--axis x]");
        MotionClient client;
        try {
            client = new MotionClient(args.get("--lcm-url", null), args.get("--prefix", "MOTION_"), "CheckCoordinator.java");
        } catch (IOException e) {
            System.err.println("CheckCoordinator: LCM unavailable: " + e.getMessage());
            System.exit(4);
            return;
        }
        boolean ok = true;
        try (MotionClient c = client) {
            health_t h = c.waitForHeartbeat("coordinator", 10000);
            if (h == null) {
                System.out.println("health: none within 10 s");
                ok = false;
            } else {
                System.out.println("health: process=" + h.process + " role=" + h.role + " state=" + MotionClient.healthStateName(h.state));
            }
            reply_t r = c.request(request_t.MOVE_ABSOLUTE, new String[] {"no_such_axis"}, new double[] {1.0}, 5000);
            System.out.println("unknown-axis: status=" + MotionClient.statusName(r.status) + " error_code=" + r.error_code + " reason=" + r.reason);
            ok &= r.status == reply_t.REJECTED && r.error_code == 2;
            r = c.request(request_t.MOVE_ABSOLUTE, new String[] {args.get("--axis", "x")}, new double[] {Double.NaN}, 5000);
            System.out.println("malformed: status=" + MotionClient.statusName(r.status) + " error_code=" + r.error_code + " reason=" + r.reason);
            ok &= r.status == reply_t.REJECTED && r.error_code == 1;
        }
        System.out.flush();
        System.exit(ok ? 0 : 1);
    }
}
