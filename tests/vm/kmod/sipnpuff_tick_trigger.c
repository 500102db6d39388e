// SPDX-License-Identifier: GPL-2.0
/*
 * sipnpuff_tick_trigger: an IIO trigger named "sipnpuff-tick", fired by a
 * hard-interrupt hrtimer `rate_hz` times a second while a buffer uses it.
 *
 * It stands in for an IMU's data-ready interrupt in the VM harness: the
 * BMI160 emulated on i2c-stub has no interrupt line, and Debian's kernel
 * builds no software trigger (CONFIG_IIO_SW_TRIGGER is unset). The BMI160
 * driver, the IIO buffer and its character device are the kernel's own.
 */
#include <linux/hrtimer.h>
#include <linux/iio/iio.h>
#include <linux/iio/trigger.h>
#include <linux/ktime.h>
#include <linux/module.h>

static unsigned int rate_hz = 200;
module_param(rate_hz, uint, 0444);
MODULE_PARM_DESC(rate_hz, "firings per second (1..10000)");

static struct iio_trigger *trigger;
static struct hrtimer timer;
static ktime_t period;

static enum hrtimer_restart fire(struct hrtimer *t)
{
	hrtimer_forward_now(t, period);
	/* In hard-interrupt context, as a device's interrupt would be. */
	iio_trigger_poll(trigger);
	return HRTIMER_RESTART;
}

static int set_state(struct iio_trigger *t, bool on)
{
	if (on)
		hrtimer_start(&timer, period, HRTIMER_MODE_REL_HARD);
	else
		hrtimer_cancel(&timer);
	return 0;
}

static const struct iio_trigger_ops ops = {
	.set_trigger_state = set_state,
};

static int __init tick_init(void)
{
	int ret;

	if (rate_hz < 1 || rate_hz > 10000)
		return -EINVAL;
	period = ns_to_ktime(NSEC_PER_SEC / rate_hz);
	hrtimer_init(&timer, CLOCK_MONOTONIC, HRTIMER_MODE_REL_HARD);
	timer.function = fire;
	trigger = iio_trigger_alloc(NULL, "sipnpuff-tick");
	if (!trigger)
		return -ENOMEM;
	trigger->ops = &ops;
	ret = iio_trigger_register(trigger);
	if (ret)
		iio_trigger_free(trigger);
	return ret;
}

static void __exit tick_exit(void)
{
	iio_trigger_unregister(trigger);
	hrtimer_cancel(&timer);
	iio_trigger_free(trigger);
}

module_init(tick_init);
module_exit(tick_exit);
MODULE_DESCRIPTION("An hrtimer IIO trigger for sipnpuff's VM harness");
MODULE_LICENSE("GPL");
