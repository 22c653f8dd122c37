# swiftd.py PIDS CONF... - starts one Swift server per CONF (account, container, object or proxy:
# the name of CONF, e.g. $S3_DIR/etc/proxy-server.conf), each in a process of its own and in one
# process (workers = 0), appends "NAME PID" lines to PIDS and exits. Each server does what
# /usr/bin/swift-*-server do (run_wsgi), plus what the test fixture needs; see start.sh and
# README.md. Adapted from the recipe in /work/shared/s3-swift (issue 29).
#
# - Swift is imported once, here, and each server forked from this process: the imports are most
#   of a server's start-up CPU (eventlet and its dependencies alone about 0.8 s), and the machines
#   that run the tests are small and busy. Swift's own workers are forked after import the same way.
# - eventlet is patched before Swift is imported (with EVENTLET_NO_GREENDNS=yes in the
#   environment): otherwise it greens every existing RLock with a gc.collect() each, about 3 s
#   a process.
# - Swift reads swift.conf and the rings in the folder of CONF, not /etc/swift, and logs to
#   stderr ($S3_DIR/log/NAME.log), not to syslog.
# - No setsid(), no chdir('/'): Swift would leave start.sh's process group, the one stop.sh (and
#   the watchdog that runs it when the test process is gone) stops.
# - The three rings are built first (one device, one replica):
#   swift-ring-builder X.builder create 8 1 1; add r1z1-127.0.0.1:PORT/d1 100; rebalance.
import eventlet
eventlet.monkey_patch(all=False, socket=True, select=True, thread=True)
import configparser, logging, os, sys
from swift.common import utils, wsgi
from swift.common.ring import RingBuilder
# what loadapp will load, so that the servers share it
import swift.account.server, swift.container.server, swift.obj.server, swift.proxy.server  # noqa: F401
import swift.common.middleware.s3api.s3api, swift.common.middleware.tempauth  # noqa: F401

utils.ThreadSafeSysLogHandler = lambda *a, **kw: logging.NullHandler()
wsgi.clean_up_daemon_hygiene = lambda: None
# A poll hub, as each server's run_server sets, not an epoll one whose fd the children would share.
eventlet.hubs.use_hub(utils.get_hub())

pids_file, confs = sys.argv[1], sys.argv[2:]
etc = os.path.dirname(confs[0])
utils.set_swift_dir(etc)

for name in ('account', 'container', 'object'):
    cp = configparser.ConfigParser()
    cp.read('%s/%s-server.conf' % (etc, name))
    b = RingBuilder(8, 1, 1)
    b.add_dev({'id': 0, 'region': 1, 'zone': 1, 'ip': '127.0.0.1', 'device': 'd1',
               'port': int(cp['DEFAULT']['bind_port']), 'weight': 100})
    b.rebalance()
    b.get_ring().save('%s/%s.ring.gz' % (etc, name))


def serve(conf, section):
    name = section[:-len('-server')]
    with open('/proc/self/comm', 'w') as comm:  # "swift-proxy" in ps -o comm, top
        comm.write('swift-' + name)
    log = os.open('%s/../log/%s.log' % (etc, name), os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o644)
    os.dup2(log, 1)
    os.dup2(log, 2)
    os.close(log)
    kw = {}
    if section == 'object-server':
        kw['global_conf_callback'] = swift.obj.server.global_conf_callback
    return wsgi.run_wsgi(conf, section, verbose=True, **kw)


sys.stdout.flush()
sys.stderr.flush()
with open(pids_file, 'a') as pids:
    for conf in confs:
        section = os.path.basename(conf)[:-len('.conf')]
        pid = os.fork()
        if pid == 0:
            try:
                code = serve(conf, section)
            except BaseException:
                import traceback
                traceback.print_exc()
                code = 1
            sys.stdout.flush()
            sys.stderr.flush()
            os._exit(code or 0)
        pids.write('%s %d\n' % (section[:-len('-server')], pid))
        pids.flush()  # not in the next child's copy of the buffer
